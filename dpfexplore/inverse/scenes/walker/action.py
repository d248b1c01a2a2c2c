"""The walker's action units: the front leg's (inverts on command) and the middle leg's.

The method is the scene's (:mod:`.solve`): per value of ``t``, the front unit's height whose
reset under the raised phase is on its aim, or the middle unit's tallest monostable height
(roots by Brent from brackets on a batch scan); then inversion pressures in one batch, and the
requirements pick among the candidates.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design
from ....solvers.dynamics.common import CLASS_MONOSTABLE
from ...engine.roots import finite_log, root_on_line
from .legs import Requirement
from .legs import requirement as _req
from .search import SCAN as _SCAN
from .search import SearchBase

__all__ = ["ActionSearch"]

#: The middle leg's action unit: the tallest whose reset is this fraction of the monostable
#: limit (a margin below the class boundary).
_MIDDLE_AIM = 0.8


class ActionSearch(SearchBase):
    """The action unit of a front or middle leg."""

    # ------------------------------------------------------------------ action unit

    def front_action(self) -> dict:
        """The front leg's action unit (module docstring)."""
        aim = self.req.front_action_aim

        def reset_error(cls: str, reset: float) -> float:
            ok = cls in ("metastable", "monostable", "bistable")
            return finite_log(reset, aim) if ok else math.nan

        def locate(grid, classes, resets, func) -> float | None:
            # the scan's classes are codes: 0, 1, 2 are the three named in reset_error
            f = np.array(
                [
                    finite_log(float(r), aim) if c in (0, 1, 2) else math.nan
                    for r, c in zip(resets, classes, strict=True)
                ]
            )
            brackets = [
                i
                for i in range(_SCAN - 1)
                if np.isfinite(f[i]) and np.isfinite(f[i + 1]) and f[i] < 0 <= f[i + 1]
            ]
            if not brackets:
                return None
            i = brackets[-1]
            h, _ = root_on_line(func, grid[i], grid[i + 1], f[i], f[i + 1], ftol=1e-3, xtol=1e-9)
            return h

        return self._action_unit("front", self.turn2, reset_error, locate)

    def middle_action(self) -> dict:
        """The middle leg's action unit (module docstring)."""
        aim = _MIDDLE_AIM * self.req.middle_action_max_reset

        def reset_error(cls: str, reset: float) -> float:
            if cls == "monostable":
                return reset - aim
            return 1.0 if cls in ("metastable", "bistable") else math.nan

        def locate(grid, classes, resets, func) -> float | None:
            below = np.flatnonzero((classes == CLASS_MONOSTABLE) & (resets < aim))
            if not below.size:
                return None
            i = int(below[-1])
            if i + 1 >= _SCAN:
                return grid[i]
            fa, fb = func(grid[i]), func(grid[i + 1])
            if np.isfinite(fa) and np.isfinite(fb) and fa < 0 <= fb:
                h, _ = root_on_line(func, grid[i], grid[i + 1], fa, fb, ftol=1e-4, xtol=1e-9)
                return h
            return grid[i]

        return self._action_unit("middle", self.walk2, reset_error, locate)

    def _action_unit(self, kind: str, phases, reset_error, locate) -> dict:
        """The action unit of the ``kind`` leg under ``phases``, cached in ``self.sections``.

        Per value of ``t``, one batch scan of heights; ``locate(grid, classes, resets, func)``
        returns the height it settles on (None: none for this ``t``), where ``func(h)`` is
        ``reset_error(class, reset)`` of a single run at height ``h``, the function whose root
        is refined. The candidates are then checked and one is picked.
        """
        if kind in self.sections:
            return self.sections[kind]
        lo, hi = self.heights("action")
        after = self.action_after(kind)
        ts = self.t_values("action")
        grid = np.linspace(lo, hi, _SCAN)
        scan = self.scan(
            [self.section("action", h, t) for t in ts for h in grid],
            phases,
            after,
            role="action",
        )
        candidates = []
        for j, t in enumerate(ts):
            rows = slice(j * _SCAN, (j + 1) * _SCAN)

            def func(h: float, t: float = float(t)) -> float:
                r = self.run(
                    self.section("action", h, t),
                    phases,
                    after,
                    atol=self.w.atol,
                    purpose="root",
                    role="action",
                )
                return reset_error(r["classes"][0], float(r["reset"][0]))

            h = locate(grid, scan["classes"][rows, 0], scan["reset"][rows, 0], func)
            if h is not None:
                candidates.append(self.section("action", h, t))
        checked = self._action_checks(candidates, kind, after)
        out = self._pick_action(checked, kind)
        self.sections[kind] = out
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
        return out + self.walking_requirements(walk, self.monostable(), kind)

    def walking_requirements(self, walk, mono, kind: str) -> list[Requirement]:
        """Requirements of the whole leg ``walk`` at the walking gait.

        Its stride against the monostable leg's ``mono`` and, for a front leg, its action unit
        flat while walking.
        """
        out = []
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
                self.stride_ratio(walk, mono),
                self.req.min_stride_ratio,
                self.stride_ratio(walk, mono) >= self.req.min_stride_ratio,
            )
        )
        return out

    @staticmethod
    def stride_ratio(walk, mono) -> float:
        """The leg's stride over the monostable leg's (inf when that one does not step)."""
        return walk.stride / mono.stride if mono.stride > 0 else math.inf

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
    ) -> list[Requirement]:
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
