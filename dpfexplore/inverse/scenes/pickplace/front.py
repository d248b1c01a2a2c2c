"""The pick-and-place scene's two-profile objective (the paper's form): difference and stiffness.

Maximise ``RT_2 - RT_1``, the difference of the objective reset time under the scene's pulse
and a second profile, with the grasp state's stiffness as the second objective. Resets diverge
at the bistable edge, so the difference is only bounded with a cap: both resets within
``max_reset``. On a few lines of ``t`` (:data:`FRONT_LINES`, spread over the lines where the
screening finds admissible designs), the difference is maximised over the admissible heights
(bounded scalar search on the full model; the cap located by a root); the line optima,
re-simulated under both profiles at the verification tolerance, with their grasp stiffness, form
the front (non-dominated), and the paper's weighted sum ``w1 (1/K)^2 + w2 / (RT_2 - RT_1)``
picks one of them when weights are given.
"""

from __future__ import annotations

import math
from typing import TypedDict

import numpy as np
from scipy.optimize import minimize_scalar

from ....model.design import Design
from ...engine.roots import finite_log, root_on_line
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .problem import ResetProblem
from .screen import DesignCheck, Screen, check_design
from .spec import PickPlaceSpec

__all__ = ["FRONT_LINES", "DifferencePoint", "solve_difference"]


class DifferencePoint(TypedDict):
    """The best design of one line of ``t``: box point, design, its two full-model runs.

    ``checks`` under the scene's pulse and the second profile; ``ok`` both admissible with
    resets within the cap; ``difference`` ``RT_2 - RT_1`` (s); ``stiffness`` of the grasp
    state (N/mm).
    """

    z: list[float]
    design: Design
    checks: list[DesignCheck]
    ok: bool
    difference: float
    stiffness: float


#: Lines of ``t`` of the difference front.
FRONT_LINES = 8


def solve_difference(
    spec: SceneSpec[PickPlaceSpec], index: int, evaluator: SceneEvaluator, screen: Screen
) -> dict:
    """The front of the difference objective (module docstring) from a complete screening."""
    p = spec.kind_spec
    d = p.difference
    problem = ResetProblem(spec, evaluator, target_index=index)
    v1, v2 = screen.ev.value, screen.second.value
    cap = d.max_reset
    with np.errstate(invalid="ignore"):
        ok = (
            screen.ev.admissible
            & screen.second.admissible
            & (v1 >= 0.05)
            & (v1 <= cap)
            & (v2 >= 0.05)
            & (v2 <= cap)
        )
    with np.errstate(invalid="ignore"):
        diff = np.where(ok, v2 - v1, np.nan).reshape(screen.shape)
    ok = ok.reshape(screen.shape)
    zh = np.linspace(0.0, 1.0, screen.shape[1])
    lines = [j for j in range(screen.shape[0]) if ok[j].any()]
    if len(lines) > FRONT_LINES:
        lines = [lines[round(k)] for k in np.linspace(0, len(lines) - 1, FRONT_LINES)]
    points = []

    def both(x: float, zt: float) -> tuple[float, float]:
        e1 = problem.resets([[x, zt]], purpose="difference", method="rodas4", atol=p.search_atol)
        e2 = problem.resets(
            [[x, zt]],
            purpose="difference",
            method="rodas4",
            atol=p.search_atol,
            pulse=d.pulse,
            profile_index=2,
        )
        return float(e1.value[0]), float(e2.value[0])

    for j in lines:
        zt = float(np.linspace(0.0, 1.0, screen.shape[0])[j])
        i_best = int(np.nanargmax(diff[j]))
        lo = hi = i_best
        while lo > 0 and ok[j, lo - 1]:
            lo -= 1
        while hi < len(zh) - 1 and ok[j, hi + 1]:
            hi += 1
        x_lo, x_hi = zh[lo], zh[hi]
        if hi < len(zh) - 1:  # the cap RT <= max_reset lies between hi and hi + 1: locate it

            def over(x: float, zt: float = zt) -> float:
                r1, r2 = both(x, zt)
                worst = max(r1, r2) if np.isfinite(r1) and np.isfinite(r2) else math.inf
                return finite_log(worst, cap) if not math.isnan(worst) else math.nan

            f_a, f_b = over(zh[hi]), over(zh[hi + 1])
            if np.isfinite(f_a) and np.isfinite(f_b) and f_a < 0 <= f_b:
                x_hi, _ = root_on_line(over, zh[hi], zh[hi + 1], f_a, f_b, ftol=1e-4)
                x_hi = zh[hi] + (x_hi - zh[hi]) * (1 - 1e-6)

        def negative(x: float, zt: float = zt) -> float:
            r1, r2 = both(x, zt)
            good = np.isfinite(r1) and np.isfinite(r2) and 0.05 <= r1 <= cap and 0.05 <= r2 <= cap
            return -(r2 - r1) if good else 1e3

        if x_hi > x_lo:
            found = minimize_scalar(
                negative, bounds=(x_lo, x_hi), method="bounded", options={"xatol": 1e-5}
            )
            x = float(found.x)
        else:
            x = float(x_lo)
        design = problem.design([x, zt])
        c1 = check_design(problem, design, atol=p.verify_atol)
        c2 = check_design(problem, design, pulse=d.pulse, atol=p.verify_atol)
        good = (
            c1["admissible"]
            and c2["admissible"]
            and all(np.isfinite(c["value"]) and 0.05 <= c["value"] <= cap for c in (c1, c2))
        )
        stiffness = float(problem.grasp_stiffness(np.array([[x, zt]]), purpose="difference")[0])
        points.append(
            {
                "z": [x, zt],
                "design": design,
                "checks": [c1, c2],
                "ok": bool(good),
                "difference": c2["value"] - c1["value"],
                "stiffness": stiffness,
            }
        )
    front = _non_dominated([q for q in points if q["ok"]])
    weighted = None
    if d.weights is not None and front:
        w1, w2 = d.weights
        weighted = min(
            front,
            key=lambda q: (
                w1 / q["stiffness"] ** 2 + w2 / q["difference"] if q["difference"] > 0 else math.inf
            ),
        )
    best = max(front, key=lambda q: q["difference"]) if front else None
    return {
        "kind": "difference",
        "target": None,
        "best": best,
        "front": front,
        "lines": points,
        "weighted": weighted,
        "problem": problem,
    }


def _non_dominated(points: list[DifferencePoint]) -> list[DifferencePoint]:
    """Points not beaten in both difference and stiffness, by difference descending."""
    out = [
        q
        for q in points
        if not any(
            o["difference"] >= q["difference"]
            and o["stiffness"] >= q["stiffness"]
            and (o["difference"] > q["difference"] or o["stiffness"] > q["stiffness"])
            for o in points
        )
    ]
    return sorted(out, key=lambda q: -q["difference"])
