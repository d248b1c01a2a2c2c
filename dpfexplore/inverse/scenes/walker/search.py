"""The walker search's pieces: section runs, batch scans, inversion pressures and bounds.

:class:`SearchBase` holds one scene run's state (the spec, the evaluator, the sections and
inversion pressures found so far) and the runs every zone's search is made of: one section under
one phase over the whole horizon (recorded in the history), a parallel batch scan of reset times
(for brackets), and the inversion pressures of the units (cached per design). The zones
(:mod:`.zones`) and the action units (:mod:`.action`) search with them; :mod:`.solve` puts
them together.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design, DesignBatch
from ....model.pressure import PressureProfile
from ....solvers.dynamics.common import CLASS_NAMES
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .inversion import inversion_method, unit_inversion_pressures
from .legs import LegComposer
from .spec import WalkerSpec

__all__ = ["SCAN", "STEP", "SearchBase"]

_CODES = {name: code for code, name in CLASS_NAMES.items()}
#: Heights of the batch scans (per t line).
SCAN = 41
#: First step (mm) of a bracket grown from a guess.
STEP = 0.004


def _code(name: str | None) -> int:
    return _CODES[name]


class SearchBase(LegComposer):
    """One scene run's sections and the runs its searches are made of."""

    def __init__(self, spec: SceneSpec[WalkerSpec], evaluator: SceneEvaluator) -> None:
        self.spec = spec
        self.w: WalkerSpec = spec.kind_spec
        self.req = self.w.requirements
        self.gait = self.w.gait
        self.evaluator = evaluator
        self.base = {s.name: s.design for s in self.w.leg.sections}
        self.legs: dict = {}
        self.sections: dict = {}
        self.inversion: dict = {}
        self.method = inversion_method()
        g = self.gait
        self.walk1 = g.phase(1)
        self.walk2 = g.phase(2)
        self.turn2 = g.phase(2, pressure=g.turn_pressure)

    # ------------------------------------------------------------------ pieces

    def horizon(self, profile: PressureProfile, after: float) -> float:
        """End of a run ``after`` s past the profile's release."""
        return profile.t_release + after

    def run(
        self,
        design: Design,
        profile: PressureProfile,
        after: float,
        *,
        atol: float,
        purpose: str,
        role: str,
        target: int = -1,
        kind: str = "simulations",
    ) -> dict:
        """One section under one phase, the whole horizon: reset times and classes (recorded)."""
        result = self.evaluator.simulate(
            design, profile, t_end=self.horizon(profile, after), atol=atol, kind=kind
        )
        out = {
            "reset": result.reset_time.copy(),
            "classes": list(result.unit_class),
            "final_state": result.final_state,
            "status": result.status.label,
            "atol": atol,
            "t_end": result.t_end,
        }
        columns = {f"reset_{k + 1}": float(result.reset_time[k]) for k in range(design.n_units)}
        columns.update({f"class_{k + 1}": _code(c) for k, c in enumerate(result.unit_class)})
        self.evaluator.record(
            DesignBatch.from_designs([design]),
            target=target,
            purpose=purpose,
            section=role,
            pressure=float(np.max(profile.pressures)),
            objective=np.nan,
            **columns,
        )
        return out

    def scan(
        self, designs: list[Design], profile: PressureProfile, after: float, *, role: str
    ) -> dict:
        """Reset times of many designs in one parallel batch (for brackets only)."""
        batch = DesignBatch.from_designs(designs)
        out = self.evaluator.reset_times(batch, profile, t_end=self.horizon(profile, after))
        n = designs[0].n_units
        self.evaluator.record(
            batch,
            target=-1,
            purpose="scan",
            section=role,
            pressure=float(np.max(profile.pressures)),
            objective=np.nan,
            **{f"reset_{k + 1}": out["reset_time"][:, k] for k in range(n)},
            **{f"class_{k + 1}": out["unit_class"][:, k] for k in range(n)},
        )
        return {"reset": out["reset_time"][:, :n], "classes": out["unit_class"][:, :n]}

    def pressures(self, designs: list[Design]) -> NDArray:
        """Inversion pressures (MPa) of every unit of each design, ``(n, max N)`` NaN-padded."""
        todo = [d for d in designs if d not in self.inversion]
        if todo:
            values = unit_inversion_pressures(todo, self.evaluator)
            for d, v in zip(todo, values, strict=True):
                self.inversion[d] = v[: d.n_units]
        width = max(d.n_units for d in designs)
        out = np.full((len(designs), width), np.nan)
        for i, d in enumerate(designs):
            out[i, : d.n_units] = self.inversion[d]
        return out

    def heights(self, role: str) -> tuple[float, float]:
        """Bounds of a section's free height (mm)."""
        v = self.w.variables[role]
        return v.bounds_of("H_1")

    def t_values(self, role: str) -> NDArray:
        """Values of ``t`` searched for a section."""
        low, high = self.w.variables[role].bounds_of("t")
        if high <= low:
            return np.array([low])
        return np.linspace(high, low, self.w.t_lines)

    def section(self, role: str, H, t: float) -> Design:
        """The base section with new heights (a list, or the first unit's for the action) and t."""
        base = self.base[role]
        if role == "action":
            H = [float(H), *base.H[1:]]
        return base.replace(H=[float(h) for h in H], t=float(t))
