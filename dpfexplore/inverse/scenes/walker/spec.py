"""Scene file of the walker-leg scene: the ``[walker]`` table (MODEL.md §10).

The ``[scene]`` table is read by :mod:`dpfexplore.inverse.scene_file`; the scene has no
``[variables]`` table (each section's are in ``[walker.variables]``). As there, every problem is
one :class:`~dpfexplore.inverse.scene_file.SceneSpecError` whose one-line message starts with
the dotted key. Times in s, pressures in MPa, lengths in mm::

    [scene]
    kind = "walker_leg"
    material = "cheetah-95a"
    [walker]
    leg = "walker-leg"             # base leg (example name or leg file): sections purple, green,
                                   # action, composition, fixed design keys
    monostable_leg = "walker-leg"  # the comparison leg, run at the scene's gait
    legs = ["front", "middle"]
    [walker.gait]
    walk_pressure = 0.2            # both phases while walking
    turn_pressure = 0.35           # phase 2 raised for one cycle: front legs turn
    phase1 = [0.0, 0.1, 1.1, 1.2]  # tau of phase 1 (purple zone)
    phase2 = [1.1, 1.2, 2.2, 2.3]  # tau of phase 2 (green zone and action section)
    period = 3.0                   # phase 1 repeats after this
    t_end = 5.0                    # tip path of one cycle
    cycles = 2                     # cycles in the timing diagram
    [walker.variables]             # per section: H (one bound for all its free units) and t
    purple = {H = {min = 1.8, max = 3.2}, t = {min = 0.55, max = 0.7}}
    green = {H = {min = 1.4, max = 2.6}, t = 1.0}
    action = {H = {min = 2.5, max = 4.2}, t = {min = 0.9, max = 1.0}}   # the action unit only
    [walker.requirements]
    pressure_margin_kPa = 10.0
    purple_reset = [1.0, 1.8]      # s after phase 1 ends: lifted through phase 2's hold, down
                                   # before phase 1 rises again
    purple_aim = [1.25, 1.55]      # root-finding aims of units 1 and 2 (inside the window)
    green_class = "monostable"
    front_action_min_reset = 3.0   # s after the raised phase 2 ends: a full gait cycle
    front_action_aim = 3.6
    middle_action_max_reset = 0.05 # monostable
    min_stride_ratio = 1.5         # over the monostable leg at the same gait
    [walker.search]
    t_lines = 4                    # values of t tried per section
    atol = 1e-5                    # mm: full model inside the root finding
    verify_atol = 1e-7             # mm: full model of every reported design
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from itertools import pairwise
from pathlib import Path
from typing import Any

from ....io.toml_fields import (
    check_keys,
    integer_in,
    interval,
    numbers,
    positive_number,
    string,
    table,
)
from ....model.pressure import PressureProfile
from ....model.variables import DesignVariables
from ....solvers.legs.leg import Leg, load_leg
from ...scene_file import SceneSpecError
from ...spec import SceneCommon

__all__ = [
    "LEG_KINDS",
    "LEG_ROLES",
    "GaitSpec",
    "WalkerRequirements",
    "WalkerSpec",
    "parse_walker",
]

LEG_ROLES = ("purple", "green", "action")
LEG_KINDS = ("front", "middle")


@dataclass(frozen=True)
class GaitSpec:
    """A two-phase gait: phase 1 drives the purple zone, phase 2 the green zone and action."""

    walk_pressure: float
    turn_pressure: float
    phase1: tuple[float, float, float, float]
    phase2: tuple[float, float, float, float]
    period: float
    t_end: float
    cycles: int

    def phase(
        self,
        number: int,
        *,
        pressure: float | None = None,
        cycles: int = 1,
        raised_first: bool = False,
    ) -> PressureProfile:
        """Profile of phase ``number`` (1 or 2) over ``cycles`` cycles.

        ``pressure`` defaults to the walking pressure; ``raised_first`` runs the first cycle at
        the turning pressure (the turning command) and the others at ``pressure``.
        """
        tau = self.phase1 if number == 1 else self.phase2
        base = self.walk_pressure if pressure is None else pressure
        pulses = []
        for c in range(cycles):
            P0 = self.turn_pressure if raised_first and c == 0 else base
            pulses.append((P0, *(v + c * self.period for v in tau)))
        return PressureProfile.pulses(pulses)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "walk_pressure": self.walk_pressure,
            "turn_pressure": self.turn_pressure,
            "phase1": list(self.phase1),
            "phase2": list(self.phase2),
            "period": self.period,
            "t_end": self.t_end,
            "cycles": self.cycles,
        }


@dataclass(frozen=True)
class WalkerRequirements:
    """What each zone must do (the scene file states them; module docstring)."""

    pressure_margin_kPa: float = 10.0
    purple_reset: tuple[float, float] = (1.0, 1.8)
    purple_aim: tuple[float, float] = (1.25, 1.55)
    green_class: str = "monostable"
    front_action_min_reset: float = 3.0
    front_action_aim: float = 3.6
    middle_action_max_reset: float = 0.05
    min_stride_ratio: float = 1.5

    @property
    def margin(self) -> float:
        """Pressure margin, MPa."""
        return self.pressure_margin_kPa / 1000.0


@dataclass(frozen=True)
class WalkerSpec:
    """The walker-leg scene (module docstring)."""

    leg: Leg
    leg_source: str
    monostable_leg: Leg
    monostable_source: str
    legs: tuple[str, ...]
    gait: GaitSpec
    variables: dict[str, DesignVariables]
    requirements: WalkerRequirements
    t_lines: int = 4
    atol: float = 1e-5
    verify_atol: float = 1e-7

    @property
    def n_results(self) -> int:
        """One result row per designed leg."""
        return len(self.legs)

    @property
    def n_units(self) -> tuple[int]:
        """The scene's numbers of units: the widest section of the leg."""
        return (max(s.design.n_units for s in self.leg.sections),)


def _leg(value: Any, where: str) -> tuple[Leg, str]:
    from ....examples import NAMES, example_path

    if not isinstance(value, str) or not value:
        raise SceneSpecError(
            f"{where} = {value!r}: an example name ({', '.join(NAMES)}) or a leg file"
        )
    path = example_path(value) if value in NAMES else Path(value)
    if not path.is_file():
        raise SceneSpecError(f"{where} = {value!r}: no such leg file or example")
    try:
        leg = load_leg(path)
    except (OSError, ValueError) as exc:
        raise SceneSpecError(f"{where} = {value!r}: {exc}") from None
    names = tuple(s.name for s in leg.sections)
    if names != LEG_ROLES or leg.composition != "dpw":
        raise SceneSpecError(
            f"{where} = {value!r}: need the walker's three sections "
            f"{', '.join(LEG_ROLES)} (composition 'dpw'), got {list(names)}"
        )
    return leg, value


def _section_variables(value: Any, where: str, design, role: str) -> DesignVariables:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table {{H, t}}")
    check_keys(value, where, required=("H",), optional=("t",))

    def section_bound(v: Any, key: str):
        if isinstance(v, Mapping):
            return interval(v, key)
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not (math.isfinite(v) and v > 0)
        ):
            raise SceneSpecError(f"{key} = {v!r}: give a number or {{min, max}}")
        return float(v)

    H = section_bound(value["H"], f"{where}.H")
    t = section_bound(value.get("t", design.t), f"{where}.t")
    n = design.n_units
    heights = [H, *design.H[1:]] if role == "action" else [H] * n
    try:
        return DesignVariables(
            n_units=n,
            H=heights,
            U_L=design.U_L[0],
            U_sep=design.U_sep[0],
            t=t,
            t_lim=design.t_lim,
            E=design.E,
            nu=design.nu,
            r_b=design.r_b,
            t_ch=design.t_ch,
            constants=design.constants,
        )
    except ValueError as exc:
        raise SceneSpecError(f"{where}: {exc}") from None


def parse_walker(data: Mapping[str, Any], common: SceneCommon) -> WalkerSpec:
    """The ``[walker]`` table (module docstring) -> :class:`WalkerSpec`."""
    if "walker" not in data:
        raise SceneSpecError("walker: missing [walker] table")
    w = table(data, "walker")
    check_keys(
        w,
        "walker",
        required=("gait", "variables"),
        optional=("leg", "monostable_leg", "legs", "requirements", "search"),
    )
    leg, source = _leg(w.get("leg", "walker-leg"), "walker.leg")
    mono, mono_source = _leg(w.get("monostable_leg", "walker-leg"), "walker.monostable_leg")
    # The scene's material and constants set: every section of both legs.
    scene = {"E": common.E, "nu": common.nu, "constants": common.constants}
    leg = replace(
        leg, sections=tuple(replace(s, design=s.design.replace(**scene)) for s in leg.sections)
    )
    mono = replace(
        mono, sections=tuple(replace(s, design=s.design.replace(**scene)) for s in mono.sections)
    )
    legs = w.get("legs", list(LEG_KINDS))
    if (
        not isinstance(legs, list)
        or not legs
        or any(k not in LEG_KINDS for k in legs)
        or len(set(legs)) != len(legs)
    ):
        raise SceneSpecError(f"walker.legs = {legs!r}: distinct entries of {', '.join(LEG_KINDS)}")
    g = table(w, "gait")
    where = "walker.gait"
    check_keys(
        g,
        where,
        required=("walk_pressure", "phase1", "phase2", "period"),
        optional=("turn_pressure", "t_end", "cycles"),
    )
    walk = positive_number(g, where, "walk_pressure", 0.2)
    turn = positive_number(g, where, "turn_pressure", walk)
    if "front" in legs and turn <= walk:
        raise SceneSpecError(
            f"{where}.turn_pressure = {turn}: must be above walk_pressure = "
            f"{walk} for a front leg (raising a phase turns the walker)"
        )
    phases = []
    for key in ("phase1", "phase2"):
        tau = numbers(g[key], f"{where}.{key}", length=4, unit="s")
        if tau[0] < 0 or any(b < a for a, b in pairwise(tau)):
            raise SceneSpecError(f"{where}.{key} = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
        phases.append((tau[0], tau[1], tau[2], tau[3]))
    period = positive_number(g, where, "period", 3.0)
    if period < max(phases[0][3], phases[1][3]) - min(phases[0][0], phases[1][0]):
        raise SceneSpecError(f"{where}.period = {period}: shorter than one cycle of both phases")
    t_end = positive_number(g, where, "t_end", max(phases[0][3], phases[1][3]) + 2.0)
    if t_end < max(phases[0][3], phases[1][3]):
        raise SceneSpecError(f"{where}.t_end = {t_end}: before the phases end")
    cycles = integer_in(g, where, "cycles", default=2, low=1, high=20)
    gait = GaitSpec(walk, turn, phases[0], phases[1], period, t_end, cycles)
    try:
        for number in (1, 2):
            gait.phase(number, cycles=cycles, raised_first=True)
    except ValueError as exc:
        raise SceneSpecError(f"{where}: {exc}") from None
    v = table(w, "variables")
    check_keys(v, "walker.variables", required=LEG_ROLES, optional=())
    variables = {
        role: _section_variables(
            v[role], f"walker.variables.{role}", leg.section(role).design, role
        )
        for role in LEG_ROLES
    }
    requirements = _requirements(w.get("requirements", {}), gait)
    search = w.get("search", {})
    if not isinstance(search, Mapping):
        raise SceneSpecError(f"walker.search = {search!r}: must be a table")
    check_keys(search, "walker.search", required=(), optional=("t_lines", "atol", "verify_atol"))
    return WalkerSpec(
        leg=leg,
        leg_source=source,
        monostable_leg=mono,
        monostable_source=mono_source,
        legs=tuple(legs),
        gait=gait,
        variables=variables,
        requirements=requirements,
        t_lines=integer_in(search, "walker.search", "t_lines", default=4, low=1, high=100),
        atol=positive_number(search, "walker.search", "atol", 1e-5),
        verify_atol=positive_number(search, "walker.search", "verify_atol", 1e-7),
    )


def _requirements(value: Any, gait: GaitSpec) -> WalkerRequirements:
    where = "walker.requirements"
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table")
    names = WalkerRequirements.__dataclass_fields__
    check_keys(value, where, required=(), optional=tuple(names))
    base = WalkerRequirements(
        front_action_min_reset=gait.period, front_action_aim=1.2 * gait.period
    )
    out: dict[str, Any] = {}
    for key in (
        "pressure_margin_kPa",
        "front_action_min_reset",
        "front_action_aim",
        "middle_action_max_reset",
        "min_stride_ratio",
    ):
        out[key] = positive_number(value, where, key, getattr(base, key), allow_zero=True)
    for key in ("purple_reset", "purple_aim"):
        pair = numbers(
            value.get(key, list(getattr(base, key))), f"{where}.{key}", length=2, unit="s"
        )
        if any(v <= 0 for v in pair):
            raise SceneSpecError(f"{where}.{key} = {list(pair)}: need times > 0 s")
        out[key] = (pair[0], pair[1])
    low, high = out["purple_reset"]
    if low > high:
        raise SceneSpecError(f"{where}.purple_reset = {[low, high]}: min above max")
    if not all(low <= a <= high for a in out["purple_aim"]):
        raise SceneSpecError(
            f"{where}.purple_aim = {list(out['purple_aim'])}: must lie in "
            f"purple_reset = {[low, high]}"
        )
    if out["front_action_aim"] < out["front_action_min_reset"]:
        raise SceneSpecError(
            f"{where}.front_action_aim = {out['front_action_aim']}: below "
            f"front_action_min_reset = {out['front_action_min_reset']}"
        )
    green = string(value, where, "green_class", default=base.green_class)
    if green not in ("monostable", "metastable", "any"):
        raise SceneSpecError(f"{where}.green_class = {green!r}: monostable, metastable or any")
    out["green_class"] = green
    return WalkerRequirements(**out)
