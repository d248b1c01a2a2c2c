"""The walker-leg scene (MODEL.md §10; the paper's Dome Phalanx Walker): zones that keep time.

A leg is three sections (:mod:`dpfexplore.solvers.legs.leg`): the purple zone (two units, phase 1),
the green zone (one unit, phase 2) and the action section (the action unit, then bistable units
that stay flat while walking; phase 2). The scene is a gait and what each zone must do
(:class:`~dpfexplore.inverse.scenes.timing_spec.WalkerRequirements`); the variables are each
section's heights and thickness. Each requirement involves one section under one phase, so each
section is designed alone, simulated only under the phase that moves it; the leg is composed only to
measure the stride (the extent of the tip path) and draw the gait.

Method
------
Reset times diverge at each unit's bistable edge, and the timing requirements sit close to it;
the map is smooth along a height but finite differences of the full model are noisy there, so
heights are found by roots (Brent's method, :func:`~.reset_problem.root_on_line`) rather than a
gradient step. Every full-model run here follows the whole horizon (no early stop: a unit may
re-invert when its neighbour snaps back, and only the last crossing is its reset).

* **Purple zone** (both units metastable, each reset time in the window ``purple_reset``; both
  invert below the walking pressure by the margin). Per value of ``t`` (``t_lines`` of them):
  the heights ``(H_1, H_2)`` that put the two reset times on their aims ``purple_aim``, by
  nested roots (for each ``H_1``, ``H_2`` by Brent; then ``H_1`` by Brent), brackets grown from
  each unit's edge on a batch scan of equal heights. The solutions are re-simulated at the
  verification tolerance, their inversion pressures computed (:mod:`.inversion`, one batch) and
  the leg's stride at the walking gait decides between those that meet every requirement.
* **Green zone** (its class, inverting below the walking pressure): a batch scan of heights per
  ``t``; the tallest that meets both (the largest motion) after its inversion pressure.
* **Front leg's action unit** (metastable under the raised phase with a reset of at least a gait
  cycle; inverting above the walking pressure and below the turning pressure by the margin, so
  it stays flat while walking and inverts on the command; the bistable units after it flat at the
  turning pressure): per ``t``, the height whose reset under the raised phase is on its aim
  (bracketed on a batch scan, Brent), then inversion pressures (one batch); of those that meet
  every requirement, the one with the largest pressure margin on both sides.
* **Middle leg's action unit** (monostable at the walking pressure, inverting below it, the
  units after it flat): per ``t``, the tallest height still monostable (the root of its reset
  time at half the limit), inversion pressures, and the walking stride decides.

Verification: every section of the reported leg is re-simulated alone at ``verify_atol`` under
its requirement's phase; the leg at the walking gait (and a front leg at the turning gait) is
simulated and composed, and the monostable leg at the same gait gives the stride ratio.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design, DesignBatch
from ....model.pressure import PressureProfile
from ....solvers.dynamics.common import CLASS_METASTABLE, CLASS_MONOSTABLE, CLASS_NAMES
from ...engine.optimiser import TargetResult
from ...evaluation import Evaluator
from ..pickplace.problem import finite_log, grow_bracket, root_on_line
from ..timing_spec import WalkerSpec
from .inversion import inversion_method, unit_inversion_pressures
from .legs import LegComposer, violation
from .legs import requirement as _req

__all__ = ["WalkerSearch", "search_of", "solve_walker", "violation"]

logger = logging.getLogger(__name__)

_CODES = {name: code for code, name in CLASS_NAMES.items()}
#: Heights of the batch scans (per t line).
_SCAN = 41
#: First step (mm) of a bracket grown from a guess.
_STEP = 0.004
#: The middle leg's action unit: the tallest whose reset is this fraction of the monostable
#: limit (a margin below the class boundary).
_MIDDLE_AIM = 0.8


def _code(name: str | None) -> int:
    return _CODES[name]


class WalkerSearch(LegComposer):
    """One scene run's sections, searches and leg simulations (cached on the evaluator)."""

    def __init__(self, spec, evaluator: Evaluator) -> None:
        self.spec = spec
        self.w: WalkerSpec = spec.walker
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

    # ------------------------------------------------------------------ purple zone

    def purple(self) -> dict:
        """The purple zone (module docstring), shared by every leg of the scene."""
        if "purple" in self.sections:
            return self.sections["purple"]
        req, w = self.req, self.w
        lo, hi = self.heights("purple")
        aims = req.purple_aim
        after = 2.0 * req.purple_reset[1] + 0.5
        ts = self.t_values("purple")
        grid = np.linspace(lo, hi, _SCAN)
        scan = self.scan(
            [self.section("purple", [h, h], t) for t in ts for h in grid],
            self.walk1,
            after,
            role="purple",
        )
        candidates = []
        for j, t in enumerate(ts):
            cls = scan["classes"][j * _SCAN : (j + 1) * _SCAN]
            edges = []
            for k in range(2):
                meta = np.flatnonzero(cls[:, k] == CLASS_METASTABLE)
                edges.append(float(grid[meta[-1]]) if meta.size else None)
            if None in edges:
                continue
            found = self._purple_roots(float(t), edges, aims, after)
            if found is not None:
                candidates.append(found)
        checked = []
        for H1, H2, t in candidates:
            design = self.section("purple", [H1, H2], t)
            check = self.run(
                design,
                self.walk1,
                after,
                atol=w.verify_atol,
                purpose="verify",
                role="purple",
                kind="verifications",
            )
            checked.append({"design": design, "check": check})
        if checked:
            p_inv = self.pressures([c["design"] for c in checked])
            for c, p in zip(checked, p_inv, strict=True):
                c["inversion"] = p
                c["requirements"] = self.purple_requirements(c["check"], p)
        ok = [c for c in checked if all(r["met"] for r in c["requirements"])]
        pool = ok or checked
        if len(pool) > 1:  # the walking stride decides (front leg: the action unit stays flat)
            for c in pool:
                c["stride"] = self.leg(
                    c["design"], self.green()["design"], self.base["action"], self.walk_phases()
                ).stride
            best = max(pool, key=lambda c: c["stride"])
        else:
            best = pool[0] if pool else None
        out = {"best": best, "candidates": checked, "met": bool(ok)}
        self.sections["purple"] = out
        return out

    def _purple_roots(self, t: float, edges: list[float], aims, after: float):
        """Heights giving both purple units their aimed reset times at ``t`` (nested roots)."""
        lo, hi = self.heights("purple")
        atol = self.w.atol
        cache: dict = {}

        def f(H1: float, H2: float) -> tuple[float, float]:
            key = (H1, H2)
            if key not in cache:
                r = self.run(
                    self.section("purple", [H1, H2], t),
                    self.walk1,
                    after,
                    atol=atol,
                    purpose="root",
                    role="purple",
                )
                vals = []
                for k in range(2):
                    ok = r["classes"][k] in ("metastable", "monostable", "bistable")
                    vals.append(finite_log(float(r["reset"][k]), aims[k]) if ok else math.nan)
                cache[key] = tuple(vals)
            return cache[key]

        guess2 = {"x": edges[1]}

        def inner(H1: float) -> float | None:
            grown = grow_bracket(lambda h: f(H1, h)[1], guess2["x"], lo=lo, hi=hi, step=_STEP)
            if grown is None:
                return None
            h2, _ = root_on_line(lambda h: f(H1, h)[1], *grown, ftol=1e-3, xtol=1e-9)
            guess2["x"] = h2
            return h2

        solved: dict[float, float] = {}

        def outer(H1: float) -> float:
            h2 = inner(H1)
            if h2 is None:
                return math.nan
            solved[H1] = h2
            return f(H1, h2)[0]

        grown = grow_bracket(outer, edges[0], lo=lo, hi=hi, step=_STEP)
        if grown is None:
            logger.info("purple t = %.4f: no bracket from the edges %s", t, edges)
            return None
        H1, _ = root_on_line(outer, *grown, ftol=1e-3, xtol=1e-9)
        H2 = solved.get(H1)
        if H2 is None:
            H2 = inner(H1)
        return None if H2 is None else (H1, H2, t)

    def purple_requirements(self, check: dict, p_inv: NDArray) -> list[dict]:
        """Requirements of the purple zone on a verified run and its inversion pressures."""
        req, g = self.req, self.gait
        low, high = req.purple_reset
        out = []
        for k in range(2):
            r = float(check["reset"][k])
            out.append(
                _req(
                    "purple",
                    f"unit {k + 1} class at {g.walk_pressure:g} MPa",
                    check["classes"][k],
                    "metastable",
                    check["classes"][k] == "metastable",
                )
            )
            out.append(
                _req(
                    "purple",
                    f"unit {k + 1} reset >= {low:g} s (lifted through phase 2's hold)",
                    r,
                    low,
                    np.isfinite(r) and r >= low,
                )
            )
            out.append(
                _req(
                    "purple",
                    f"unit {k + 1} reset <= {high:g} s (down before phase 1 rises again)",
                    r,
                    high,
                    np.isfinite(r) and r <= high,
                )
            )
            out.append(
                _req(
                    "purple",
                    f"unit {k + 1} inverts below walking pressure - margin",
                    float(p_inv[k]),
                    g.walk_pressure - req.margin,
                    bool(p_inv[k] <= g.walk_pressure - req.margin),
                )
            )
        return out

    # ------------------------------------------------------------------ green zone

    def green(self) -> dict:
        """The green zone: the tallest height of its class that inverts below walking pressure."""
        if "green" in self.sections:
            return self.sections["green"]
        req, g = self.req, self.gait
        lo, hi = self.heights("green")
        ts = self.t_values("green")
        grid = np.linspace(lo, hi, _SCAN)
        scan = self.scan(
            [self.section("green", [h], t) for t in ts for h in grid], self.walk2, 1.0, role="green"
        )
        wanted = {
            "monostable": [CLASS_MONOSTABLE],
            "metastable": [CLASS_METASTABLE],
            "any": [CLASS_MONOSTABLE, CLASS_METASTABLE],
        }[req.green_class]
        rows = np.flatnonzero(np.isin(scan["classes"][:, 0], wanted))
        order = sorted(rows, key=lambda i: -grid[i % _SCAN])[:6]
        designs = [self.section("green", [grid[i % _SCAN]], ts[i // _SCAN]) for i in order]
        p_inv = self.pressures(designs)[:, 0] if designs else np.empty(0)
        best = None
        for design, p in zip(designs, p_inv, strict=True):
            if p <= g.walk_pressure - req.margin:
                best = design
                break
        if best is None:
            best = designs[0] if designs else self.base["green"]
        check = self.run(
            best,
            self.walk2,
            1.0,
            atol=self.w.verify_atol,
            purpose="verify",
            role="green",
            kind="verifications",
        )
        p = self.pressures([best])[0]
        out = {
            "design": best,
            "check": check,
            "inversion": p,
            "requirements": self.green_requirements(check, p),
        }
        self.sections["green"] = out
        return out

    def green_requirements(self, check: dict, p_inv: NDArray) -> list[dict]:
        """Requirements of the green zone on a verified run and its inversion pressure."""
        req, g = self.req, self.gait
        cls = check["classes"][0]
        return [
            _req(
                "green",
                f"unit 1 class at {g.walk_pressure:g} MPa",
                cls,
                req.green_class,
                cls == req.green_class
                or (req.green_class == "any" and cls in ("monostable", "metastable")),
            ),
            _req(
                "green",
                "unit 1 inverts below walking pressure - margin",
                float(p_inv[0]),
                g.walk_pressure - req.margin,
                bool(p_inv[0] <= g.walk_pressure - req.margin),
            ),
        ]

    # ------------------------------------------------------------------ action unit

    def front_action(self) -> dict:
        """The front leg's action unit (module docstring)."""
        if "front" in self.sections:
            return self.sections["front"]
        req, w = self.req, self.w
        lo, hi = self.heights("action")
        aim = req.front_action_aim
        after = self.action_after("front")
        ts = self.t_values("action")
        grid = np.linspace(lo, hi, _SCAN)
        scan = self.scan(
            [self.section("action", h, t) for t in ts for h in grid],
            self.turn2,
            after,
            role="action",
        )
        candidates = []
        for j, t in enumerate(ts):
            cls = scan["classes"][j * _SCAN : (j + 1) * _SCAN, 0]
            reset = scan["reset"][j * _SCAN : (j + 1) * _SCAN, 0]
            f = np.array(
                [
                    finite_log(float(r), aim) if c in (0, 1, 2) else math.nan
                    for r, c in zip(reset, cls, strict=True)
                ]
            )
            brackets = [
                i
                for i in range(_SCAN - 1)
                if np.isfinite(f[i]) and np.isfinite(f[i + 1]) and f[i] < 0 <= f[i + 1]
            ]
            if not brackets:
                continue
            i = brackets[-1]

            def func(h: float, t: float = float(t)) -> float:
                r = self.run(
                    self.section("action", h, t),
                    self.turn2,
                    after,
                    atol=w.atol,
                    purpose="root",
                    role="action",
                )
                ok = r["classes"][0] in ("metastable", "monostable", "bistable")
                return finite_log(float(r["reset"][0]), aim) if ok else math.nan

            h, _ = root_on_line(func, grid[i], grid[i + 1], f[i], f[i + 1], ftol=1e-3, xtol=1e-9)
            candidates.append(self.section("action", h, t))
        checked = self._action_checks(candidates, "front", after)
        out = self._pick_action(checked, "front")
        self.sections["front"] = out
        return out

    def middle_action(self) -> dict:
        """The middle leg's action unit (module docstring)."""
        if "middle" in self.sections:
            return self.sections["middle"]
        req, w = self.req, self.w
        lo, hi = self.heights("action")
        cap = req.middle_action_max_reset
        after = self.action_after("middle")
        ts = self.t_values("action")
        grid = np.linspace(lo, hi, _SCAN)
        scan = self.scan(
            [self.section("action", h, t) for t in ts for h in grid],
            self.walk2,
            after,
            role="action",
        )
        aim = _MIDDLE_AIM * cap
        candidates = []
        for j, t in enumerate(ts):
            cls = scan["classes"][j * _SCAN : (j + 1) * _SCAN, 0]
            reset = scan["reset"][j * _SCAN : (j + 1) * _SCAN, 0]
            below = np.flatnonzero((cls == CLASS_MONOSTABLE) & (reset < aim))
            if not below.size:
                continue
            i = int(below[-1])
            if i + 1 >= _SCAN:
                candidates.append(self.section("action", grid[i], t))
                continue

            def func(h: float, t: float = float(t)) -> float:
                r = self.run(
                    self.section("action", h, t),
                    self.walk2,
                    after,
                    atol=w.atol,
                    purpose="root",
                    role="action",
                )
                c = r["classes"][0]
                if c == "monostable":
                    return float(r["reset"][0]) - aim
                return 1.0 if c in ("metastable", "bistable") else math.nan

            fa, fb = func(grid[i]), func(grid[i + 1])
            h = grid[i]
            if np.isfinite(fa) and np.isfinite(fb) and fa < 0 <= fb:
                h, _ = root_on_line(func, grid[i], grid[i + 1], fa, fb, ftol=1e-4, xtol=1e-9)
            candidates.append(self.section("action", h, t))
        checked = self._action_checks(candidates, "middle", after)
        out = self._pick_action(checked, "middle")
        self.sections["middle"] = out
        return out

    def _action_checks(self, designs: list[Design], kind: str, after: float) -> list[dict]:
        if not designs:
            return []
        p_inv = self.pressures(designs)
        checked = []
        profile = self.turn2 if kind == "front" else self.walk2
        purple = self.purple()["best"] if kind == "front" else None
        purple_max = float(np.max(purple["inversion"])) if purple else math.nan
        for design, p in zip(designs, p_inv, strict=True):
            check = self.run(
                design,
                profile,
                after,
                atol=self.w.verify_atol,
                purpose="verify",
                role="action",
                kind="verifications",
            )
            checked.append(
                {
                    "design": design,
                    "check": check,
                    "inversion": p,
                    "requirements": self.action_requirements(check, p, kind, purple_max),
                }
            )
        return checked

    def action_after(self, kind: str) -> float:
        """Seconds simulated after the action section's phase (its reset horizon)."""
        return 2.0 * self.req.front_action_aim + 0.5 if kind == "front" else 1.0

    def assess(
        self,
        purple: Design,
        green: Design,
        action: Design,
        kind: str,
        *,
        purpose: str = "baseline",
        target: int = -1,
    ) -> list[dict]:
        """Every requirement of one whole leg, at the search tolerance (a black-box objective).

        The benchmark's baselines minimise :func:`violation` of this; our search meets the
        same requirements section by section.
        """
        atol = self.w.atol
        after_p = 2.0 * self.req.purple_reset[1] + 0.5
        checks = [
            self.run(
                purple,
                self.walk1,
                after_p,
                atol=atol,
                purpose=purpose,
                role="purple",
                target=target,
            ),
            self.run(
                green, self.walk2, 1.0, atol=atol, purpose=purpose, role="green", target=target
            ),
            self.run(
                action,
                self.turn2 if kind == "front" else self.walk2,
                self.action_after(kind),
                atol=atol,
                purpose=purpose,
                role="action",
                target=target,
            ),
        ]
        p_inv = self.pressures([purple, green, action])
        out = self.purple_requirements(checks[0], p_inv[0][:2])
        out += self.green_requirements(checks[1], p_inv[1][:1])
        out += self.action_requirements(checks[2], p_inv[2], kind, float(np.nanmax(p_inv[0][:2])))
        walk = self.leg(purple, green, action, self.walk_phases())
        mono = self.monostable()
        ratio = walk.stride / mono.stride if mono.stride > 0 else math.inf
        if kind == "front":
            flat = walk.sections[2].result.unit_class[0] is None
            out.append(
                _req(
                    "action",
                    "action unit flat while walking (leg run at the walking gait)",
                    flat,
                    True,
                    flat,
                )
            )
        out.append(
            _req(
                "leg",
                f"stride >= {self.req.min_stride_ratio:g} x the monostable leg's at the same gait",
                ratio,
                self.req.min_stride_ratio,
                ratio >= self.req.min_stride_ratio,
            )
        )
        return out

    def _pick_action(self, checked: list[dict], kind: str) -> dict:
        ok = [c for c in checked if all(r["met"] for r in c["requirements"])]
        pool = ok or checked
        g = self.gait
        if not pool:
            return {"best": None, "candidates": [], "met": False}
        if kind == "front":
            # The largest pressure margin on both sides: flat while walking, inverted on command.
            best = max(
                pool,
                key=lambda c: min(
                    c["inversion"][0] - g.walk_pressure, g.turn_pressure - c["inversion"][0]
                ),
            )
        else:
            purple = self.purple()["best"]["design"]
            for c in pool:
                c["stride"] = self.leg(
                    purple, self.green()["design"], c["design"], self.walk_phases()
                ).stride
            best = max(pool, key=lambda c: c["stride"])
        return {"best": best, "candidates": checked, "met": bool(ok)}

    def action_requirements(
        self, check: dict, p_inv: NDArray, kind: str, purple_max: float = math.nan
    ) -> list[dict]:
        """Requirements of a front or middle leg's action section (verified run, pressures).

        ``purple_max``: the highest inversion pressure of the purple zone (MPa, front legs).
        """
        req, g = self.req, self.gait
        m = req.margin
        cls, r = check["classes"][0], float(check["reset"][0])
        rest_flat = all(c is None for c in check["classes"][1:])
        first_rest = float(np.nanmin(p_inv[1:])) if np.any(np.isfinite(p_inv[1:])) else math.inf
        if kind == "front":
            return [
                _req(
                    "action",
                    f"action unit class at {g.turn_pressure:g} MPa (raised phase)",
                    cls,
                    "metastable",
                    cls == "metastable",
                ),
                _req(
                    "action",
                    f"action unit reset >= {req.front_action_min_reset:g} s (a gait cycle)",
                    r,
                    req.front_action_min_reset,
                    np.isfinite(r) and r >= req.front_action_min_reset,
                ),
                _req(
                    "action",
                    "action unit inverts above walking pressure + margin (flat while walking)",
                    float(p_inv[0]),
                    g.walk_pressure + m,
                    bool(p_inv[0] >= g.walk_pressure + m),
                ),
                _req(
                    "action",
                    "action unit inverts below turning pressure - margin",
                    float(p_inv[0]),
                    g.turn_pressure - m,
                    bool(p_inv[0] <= g.turn_pressure - m),
                ),
                _req(
                    "action",
                    "action unit inverts above every purple unit",
                    float(p_inv[0]),
                    purple_max,
                    bool(p_inv[0] > purple_max),
                ),
                _req(
                    "action",
                    "units after it flat at the turning pressure (run)",
                    rest_flat,
                    True,
                    rest_flat,
                ),
                _req(
                    "action",
                    "units after it invert above turning pressure + margin",
                    first_rest,
                    g.turn_pressure + m,
                    bool(first_rest >= g.turn_pressure + m),
                ),
            ]
        return [
            _req(
                "action",
                f"action unit class at {g.walk_pressure:g} MPa",
                cls,
                "monostable",
                cls == "monostable",
            ),
            _req(
                "action",
                f"action unit reset <= {req.middle_action_max_reset:g} s",
                r,
                req.middle_action_max_reset,
                np.isfinite(r) and r <= req.middle_action_max_reset,
            ),
            _req(
                "action",
                "action unit inverts below walking pressure - margin",
                float(p_inv[0]),
                g.walk_pressure - m,
                bool(p_inv[0] <= g.walk_pressure - m),
            ),
            _req(
                "action",
                "units after it flat at the walking pressure (run)",
                rest_flat,
                True,
                rest_flat,
            ),
            _req(
                "action",
                "units after it invert above walking pressure + margin",
                first_rest,
                g.walk_pressure + m,
                bool(first_rest >= g.walk_pressure + m),
            ),
        ]


def search_of(spec, evaluator: Evaluator) -> WalkerSearch:
    """The scene run's search (one per evaluator, shared by its legs)."""
    if "walker" not in evaluator.cache:
        evaluator.cache["walker"] = WalkerSearch(spec, evaluator)
    return evaluator.cache["walker"]


def solve_walker(spec, target_index: int, evaluator: Evaluator) -> TargetResult:
    """Design one leg of the scene (``legs[target_index]``: front or middle)."""
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    kind = spec.walker.legs[target_index]
    search = search_of(spec, evaluator)
    purple, green = search.purple(), search.green()
    action = search.front_action() if kind == "front" else search.middle_action()
    extra = {
        "kind": kind,
        "purple": purple,
        "green": green,
        "action": action,
        "inversion_method": search.method,
    }
    ok = purple["best"] is not None and action["best"] is not None
    if ok:
        designs = (purple["best"]["design"], green["design"], action["best"]["design"])
        walk = search.leg(*designs, search.walk_phases())
        mono = search.monostable()
        extra["walk"], extra["monostable"] = walk, mono
        ratio = walk.stride / mono.stride if mono.stride > 0 else math.inf
        requirements = (
            purple["best"]["requirements"] + green["requirements"] + action["best"]["requirements"]
        )
        if kind == "front":
            flat = walk.sections[2].result.unit_class[0] is None
            requirements.append(
                _req(
                    "action",
                    "action unit flat while walking (leg run at the walking gait)",
                    flat,
                    True,
                    flat,
                )
            )
            extra["turn"] = search.leg(*designs, search.turn_phases())
        requirements.append(
            _req(
                "leg",
                f"stride >= {search.req.min_stride_ratio:g} x the "
                "monostable leg's at the same gait",
                ratio,
                search.req.min_stride_ratio,
                ratio >= search.req.min_stride_ratio,
            )
        )
        extra["requirements"] = requirements
        extra["stride_ratio"] = ratio
        cycles = search.gait.cycles
        t_diag = search.gait.period * cycles + 2.0
        extra["timing"] = {"walk": search.leg(*designs, search.walk_phases(cycles), t_end=t_diag)}
        if kind == "front":
            extra["timing"]["turn"] = search.leg(*designs, search.turn_phases(cycles), t_end=t_diag)
    reachable = ok and all(r["met"] for r in extra.get("requirements", []))
    if ok:  # the leg's objective in the history: 0 once every requirement is met
        evaluator.record(
            DesignBatch.from_designs([designs[0]]),
            target=target_index,
            purpose="result",
            section="leg",
            objective=violation(extra["requirements"]),
        )
    result = TargetResult(
        target_index=target_index, target=(kind,), best=None, reachable=bool(reachable), extra=extra
    )
    result.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    result.wall_s = evaluator.wall_s - wall0
    return result
