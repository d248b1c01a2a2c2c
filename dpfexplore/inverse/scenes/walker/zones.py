"""The walker's timing zones: the purple zone (two metastable units) and the green zone.

The method is the scene's (:mod:`.solve`): per value of ``t``, the purple heights that put both
reset times on their aims by nested roots (Brent) from brackets grown on a batch scan; the green
height from a batch scan (the tallest of its class that inverts below the walking pressure).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from ....solvers.dynamics.common import CLASS_METASTABLE, CLASS_MONOSTABLE
from ...engine.roots import finite_log, grow_bracket, root_on_line
from .legs import Requirement
from .legs import requirement as _req
from .search import SCAN as _SCAN
from .search import STEP as _STEP
from .search import SearchBase

__all__ = ["ZoneSearch"]

logger = logging.getLogger(__name__)


class ZoneSearch(SearchBase):
    """The purple and green zones of a scene run (shared by every leg)."""

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

    def purple_requirements(self, check: dict, p_inv: NDArray) -> list[Requirement]:
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

    def green_requirements(self, check: dict, p_inv: NDArray) -> list[Requirement]:
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
