"""The pick-and-place scene (paper eq. opti_pick_and_place; MODEL.md §9): reset times by design.

The variables are one height (the tied ``H_5 = H_6``) and ``t``; the objective reset time (the
scene's unit, by default the last non-hold unit to reset: the object is released) is smooth
along lines of constant ``t`` except at class changes, and diverges at the bistable edge
(:mod:`.problem`). Finite differences of the full model are noisy at the integrator's
tolerance there, so the optimiser here does not use them: it brackets and roots.

Method
------
1. **Screening** (:mod:`.screen`, once per scene run, shared by its targets): a grid
   of ``grid.t`` lines of constant ``t`` with ``grid.H`` heights each; the fast reset model on the
   rows of its trained domain (where its trained scene is the scene's pulse), the release model
   on the others only when needed, the grasp stiffness by the statics. It also gives the
   reachable range of reset times (its extremes re-simulated in the full model).
2. **Target reset time.** The sign changes of ``log(reset / target)`` between neighbours on the
   lines (:func:`line_brackets`), inside the fitted range first when ``prefer_fitted``, stiffest
   grasp first. A bracket is closed on the screening model first (Brent's method, cheap), then
   on the full model (``search_atol``): run at the screening model's root, then at a step set by
   its slope, and Brent's method on the bracket that makes, stopping within a tenth of the
   tolerance. The design is re-simulated alone to the horizon at ``verify_atol`` (no early
   stop) and accepted if its reset time is within the tolerance and its hold units stay
   inverted; else the next bracket. No bracket anywhere: the target is out of reach, and the
   nearest verified design and the range are reported.
3. **Reset times of two units** (``unit_targets``: e.g. the paper's finger's 2.657 and 1.613 s):
   two equations in the two variables, solved by nested roots: for each ``t``, the height that
   gives the first unit its time (Brent, bracket grown from the screening's estimate); then
   Brent on ``t`` for the second unit's time between lines of opposite error, or the smallest
   error near the best line when the two level curves run side by side (they nearly do for the
   paper's finger). Inside the fitted range first among the answers within the tolerance.
4. **Difference of two profiles** (``difference``, :mod:`.front`): the front of
   ``RT_2 - RT_1`` against the grasp stiffness, and the paper's weighted sum.

Only the full model's values are reported; every reported design is re-simulated alone.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from itertools import pairwise
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq, minimize_scalar

from ....model.design import Design
from ...engine.roots import grow_bracket, root_on_line
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .front import DifferencePoint, solve_difference
from .problem import Bracket, ResetProblem, line_brackets
from .screen import DesignCheck, Screen, check_design, screen_pickplace, second_screen
from .spec import PickPlaceSpec

__all__ = ["SEARCH_FRACTION", "Attempt", "PickPlaceOutcome", "solve_pickplace"]

logger = logging.getLogger(__name__)

#: Brackets tried per target before it is declared out of reach.
MAX_BRACKETS = 6
#: Lines of ``t`` whose exact two-unit error is computed (those the screening puts nearest).
CANDIDATE_LINES = 6
#: Search tolerance as a fraction of the scene's (a margin for the verification).
SEARCH_FRACTION = 0.1
#: ``|log(reset / target)|`` at or above this marks an end that diverged (bistable) or went
#: negative (:data:`dpfexplore.inverse.engine.roots.LOG_INF` is 50).
_DIVERGED = 40.0


class Attempt(TypedDict, total=False):
    """A design tried for a target: box point, design, its full-model check and error.

    ``error`` is the relative error of the objective reset time (the largest of the two units'
    for a unit target, with ``unit_errors``); ``root_evaluations`` the runs that found it;
    ``bracket`` the screening bracket it closed (None: the nearest screening design).
    """

    z: list[float]
    design: Design
    check: DesignCheck
    error: float
    unit_errors: list[float]
    root_evaluations: int | dict
    bracket: Bracket | None


@dataclass
class PickPlaceOutcome:
    """What the search found for one result row of a pick-and-place scene (before verification).

    Attributes
    ----------
    target_index : int
    kind : str
        ``"target"``, ``"unit_target"`` or ``"difference"``.
    target : float, list of float or None
        The target reset time (s), the unit targets' times, or None (difference).
    best : Attempt, DifferencePoint or None
    reachable : bool
    attempts : list of Attempt
    brackets : int
        Brackets (or two-unit solutions) found.
    units : list of int or None
        The unit target's units (1-based).
    front, lines : list of DifferencePoint
        The difference front and every line's optimum.
    weighted : DifferencePoint or None
    counts : dict of str to int
        Evaluations of this result by kind.
    wall_s : float
        Seconds spent on this result.
    """

    target_index: int
    kind: str
    target: float | list[float] | None
    best: Attempt | DifferencePoint | None
    reachable: bool
    attempts: list[Attempt] = field(default_factory=list)
    brackets: int = 0
    units: list[int] | None = None
    front: list[DifferencePoint] = field(default_factory=list)
    lines: list[DifferencePoint] = field(default_factory=list)
    weighted: DifferencePoint | None = None
    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0


# ----------------------------------------------------------------------------- one target


def _order(brackets: list[Bracket], prefer_fitted: bool) -> list[Bracket]:
    return sorted(
        brackets,
        key=lambda b: (
            prefer_fitted and not b.in_fitted_range,
            -np.nan_to_num(b.stiffness, nan=-np.inf),
        ),
    )


def _brackets(screen: Screen, target: float, prefer_fitted: bool) -> list[Bracket]:
    return _order(
        line_brackets(
            screen.ev, screen.shape, target, fitted=screen.fitted, stiffness=screen.stiffness
        ),
        prefer_fitted,
    )


def _solve_target(
    spec: SceneSpec[PickPlaceSpec], index: int, evaluator: SceneEvaluator, screen: Screen
) -> dict:
    p = spec.kind_spec
    target = p.targets[index]
    problem = ResetProblem(spec, evaluator, target_index=index)
    brackets = _brackets(screen, target, p.prefer_fitted)
    if not brackets or (p.prefer_fitted and not brackets[0].in_fitted_range):
        screen = screen_pickplace(spec, evaluator, complete=True)  # the rest of the box
        brackets = _brackets(screen, target, p.prefer_fitted)
    ftol = math.log1p(SEARCH_FRACTION * p.tolerance)
    attempts = []
    for bracket in brackets[:MAX_BRACKETS]:
        x, calls = _close_bracket(problem, screen, bracket, target, ftol)
        zt = bracket.z_lo[1]
        design = problem.design([x, zt])
        check = check_design(problem, design, atol=p.verify_atol)
        error = abs(check["value"] / target - 1.0) if check["admissible"] else math.inf
        attempts.append(
            {
                "z": [x, zt],
                "design": design,
                "check": check,
                "error": error,
                "root_evaluations": calls,
                "bracket": bracket,
            }
        )
        logger.info(
            "pickplace target %.4g s: bracket t-line %.4f -> reset %.5g s (error %.2e)",
            target,
            zt,
            check["value"],
            error,
        )
        if error <= p.tolerance:
            break
    best = min(attempts, key=lambda a: a["error"]) if attempts else None
    if best is None or best["error"] > p.tolerance:
        screen = screen_pickplace(spec, evaluator, complete=True)
        nearest = _nearest(problem, screen, target)
        if nearest is not None and (best is None or nearest["error"] < best["error"]):
            best = nearest
    return {
        "kind": "target",
        "target": target,
        "best": best,
        "attempts": attempts,
        "brackets": len(brackets),
        "problem": problem,
    }


def _close_bracket(
    problem: ResetProblem, screen: Screen, bracket: Bracket, target: float, ftol: float
) -> tuple[float, dict]:
    """The root of a bracket: first on the screening model, then polished on the full model.

    The screening model is cheap and (the fast model) within about 0.1 % of the full model
    here, so its root is where the full model's is to that accuracy: the full model is first
    run there, then at a step from there set by the screening model's slope, and Brent's method
    closes the bracket that makes (stopping within ``ftol``). Returns the root and the number
    of runs of each model.
    """
    p = problem.p
    zt = bracket.z_lo[1]
    rows = [
        int(np.argmin(np.sum((screen.ev.z - np.array(z)) ** 2, axis=1)))
        for z in (bracket.z_lo, bracket.z_hi)
    ]
    methods = {str(screen.ev.extra["methods"][r]) for r in rows}
    surrogate = "fast" if methods <= {"fast"} else "release"
    full_cache: dict[float, float] = {}

    def sur(x: float) -> float:
        ev = problem.resets([[x, zt]], purpose="surrogate", method=surrogate)
        return float(ev.log_ratio(target)[0])

    def full(x: float) -> float:
        if x not in full_cache:
            ev = problem.resets(
                [[x, zt]],
                purpose="root",
                method="rodas4",
                atol=p.search_atol,
                objective_target=target,
            )
            full_cache[x] = float(ev.log_ratio(target)[0])
        return full_cache[x]

    lo, hi = bracket.z_lo[0], bracket.z_hi[0]
    x_s, n_sur = root_on_line(sur, lo, hi, bracket.f_lo, bracket.f_hi, ftol=0.1 * ftol)
    f_s = full(x_s)
    if np.isfinite(f_s) and abs(f_s) <= ftol:
        return x_s, {"surrogate": n_sur, "full": len(full_cache)}
    step = 1e-4 * (hi - lo)
    if np.isfinite(f_s):
        d = 1e-3 * (hi - lo)
        slope = (sur(min(x_s + d, hi)) - sur(max(x_s - d, lo))) / (
            min(x_s + d, hi) - max(x_s - d, lo)
        )
        n_sur += 2
        if np.isfinite(slope) and slope != 0:
            step = float(np.clip(1.5 * abs(f_s / slope), 1e-9, hi - lo))
    grown = grow_bracket(full, x_s, lo=lo, hi=hi, step=step, limit=20)
    if grown is not None:
        x, _ = root_on_line(full, *grown, ftol=ftol)
    else:  # the screening model misled: the whole bracket on the full model
        x, _ = root_on_line(full, lo, hi, bracket.f_lo, bracket.f_hi, ftol=ftol)
    return x, {"surrogate": n_sur, "full": len(full_cache)}


def _nearest(problem: ResetProblem, screen: Screen, target: float) -> Attempt | None:
    """The screening design nearest the target (log scale), verified in the full model."""
    f = np.abs(screen.ev.log_ratio(target))
    if not np.any(np.isfinite(f)):
        return None
    i = int(np.nanargmin(f))
    design = problem.design(screen.ev.z[i])
    check = check_design(problem, design, atol=problem.p.verify_atol)
    error = abs(check["value"] / target - 1.0) if check["admissible"] else math.inf
    return {
        "z": list(screen.ev.z[i]),
        "design": design,
        "check": check,
        "error": error,
        "root_evaluations": 0,
        "bracket": None,
    }


# ----------------------------------------------------------------------------- two units


def _line_estimate(f1: NDArray, f2: NDArray, zh: NDArray) -> tuple[float, float] | None:
    """On one screened line: where ``f1`` crosses 0 (linear) and ``f2`` there (linear)."""
    for i in range(len(zh) - 1):
        a, b = f1[i], f1[i + 1]
        if not (np.isfinite(a) and np.isfinite(b)) or (a < 0) == (b < 0):
            continue
        if max(abs(a), abs(b)) >= _DIVERGED:  # a diverging end: the estimate is the other end
            w = 0.0 if abs(a) < abs(b) else 1.0
        else:
            w = -a / (b - a)
        x = zh[i] + w * (zh[i + 1] - zh[i])
        c, d = f2[i], f2[i + 1]
        if not (np.isfinite(c) and np.isfinite(d)):
            continue
        return float(x), float(c + w * (d - c))
    return None


def _solve_units(
    spec: SceneSpec[PickPlaceSpec], index: int, evaluator: SceneEvaluator, screen: Screen
) -> dict:
    p = spec.kind_spec
    goal = p.unit_targets[index - len(p.targets)]
    (u1, u2), (t1, t2) = goal.units, goal.reset
    problem = ResetProblem(spec, evaluator, target_index=index)
    hold = problem.hold
    ftol = math.log1p(SEARCH_FRACTION * p.tolerance)
    zh = np.linspace(0.0, 1.0, screen.shape[1])
    f1 = screen.ev.unit_log_ratio(u1, t1, hold).reshape(screen.shape)
    f2 = screen.ev.unit_log_ratio(u2, t2, hold).reshape(screen.shape)
    lines = np.linspace(0.0, 1.0, screen.shape[0])
    estimates = [_line_estimate(f1[j], f2[j], zh) for j in range(screen.shape[0])]
    cache: dict = {}

    def unit_f(x: float, zt: float) -> tuple[float, float]:
        key = (x, zt)
        if key not in cache:
            ev = problem.resets([[x, zt]], purpose="root", method="rodas4", atol=p.search_atol)
            cache[key] = (
                float(ev.unit_log_ratio(u1, t1, hold)[0]),
                float(ev.unit_log_ratio(u2, t2, hold)[0]),
            )
        return cache[key]

    inner_at: dict[float, float] = {}

    def inner(zt: float, guess: float) -> float | None:
        grown = grow_bracket(lambda x: unit_f(x, zt)[0], guess)
        if grown is None:
            return None
        x, _ = root_on_line(lambda x: unit_f(x, zt)[0], *grown, ftol=ftol * 0.1)
        inner_at[zt] = x
        return x

    def guess_at(zt: float) -> float:
        known = [(abs(k - zt), v) for k, v in inner_at.items()]
        if known:
            return min(known)[1]
        j = int(np.argmin(np.abs(lines - zt)))
        est = estimates[j] or next((e for e in estimates if e is not None), (0.5, 0.0))
        return est[0]

    def outer(zt: float) -> float:
        x = inner(zt, guess_at(zt))
        if x is None:
            return math.nan
        return unit_f(x, zt)[1]

    # Lines where the screening puts the second unit near its time; their exact values (inner
    # root on the full model), then a root in t between lines of opposite sign, or the smallest
    # |error| near the best line when the two level curves run side by side (they nearly do for
    # the paper's finger: its two tip units keep their ratio of reset times along the curve).
    known = [(j, e) for j, e in enumerate(estimates) if e is not None]
    if not known:
        return {
            "kind": "unit_target",
            "target": list(goal.reset),
            "units": list(goal.units),
            "best": None,
            "attempts": [],
            "brackets": 0,
            "problem": problem,
        }
    near = sorted(known, key=lambda je: abs(je[1][1]))[:CANDIDATE_LINES]
    exact = {}
    for j, (x0, _) in sorted(near):
        x = inner(float(lines[j]), x0)
        if x is not None:
            exact[j] = unit_f(x, float(lines[j]))[1]
    solutions = []
    js = sorted(exact)
    for a, b in pairwise(js):
        if b == a + 1 and (exact[a] < 0) != (exact[b] < 0):
            za, zb, ga, gb = float(lines[a]), float(lines[b]), exact[a], exact[b]
            try:
                zt = brentq(_finite_or, za, zb, args=(outer, ga, gb, za, zb), xtol=1e-9, maxiter=60)
                solutions.append(zt)
            except ValueError:
                pass
    # Lines already within half the tolerance are answers as they stand.
    solutions += [float(lines[j]) for j in js if abs(exact[j]) <= math.log1p(0.5 * p.tolerance)]
    if not solutions and exact:
        j = min(exact, key=lambda k: abs(exact[k]))
        step = float(lines[1] - lines[0]) if len(lines) > 1 else 0.0
        lo, hi = max(0.0, float(lines[j]) - step), min(1.0, float(lines[j]) + step)
        found = minimize_scalar(
            lambda v: abs(np.nan_to_num(outer(v), nan=1e3)),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-6, "maxiter": 30},
        )
        solutions.append(float(found.x))
    attempts = []
    for zt in solutions:
        x = inner_at.get(zt)
        if x is None:
            x = inner(zt, guess_at(zt))
        if x is None:
            continue
        design = problem.design([x, zt])
        check = check_design(problem, design, atol=p.verify_atol)
        r = check["reset_times"]
        errors = [abs(r[u1 - 1] / t1 - 1.0), abs(r[u2 - 1] / t2 - 1.0)]
        ok = check["admissible"] and all(np.isfinite(errors))
        error = max(errors) if ok else math.inf
        attempts.append(
            {
                "z": [x, zt],
                "design": design,
                "check": check,
                "error": error,
                "unit_errors": errors,
                "root_evaluations": len(cache),
            }
        )
    # Inside the fitted range first among those that meet the tolerance, then the smallest error.
    best = min(
        attempts,
        key=lambda a: (
            a["error"] > p.tolerance,
            p.prefer_fitted and not a["design"].in_fitted_range,
            a["error"],
        ),
        default=None,
    )
    return {
        "kind": "unit_target",
        "target": list(goal.reset),
        "units": list(goal.units),
        "best": best,
        "attempts": attempts,
        "brackets": len(solutions),
        "problem": problem,
    }


def _finite_or(v: float, outer, ga: float, gb: float, a: float, b: float) -> float:
    # An outer point whose inner root failed takes the sign of the nearer end (keeps Brent going).
    value = outer(v)
    if np.isfinite(value):
        return value
    return ga if abs(v - a) < abs(v - b) else gb


# ----------------------------------------------------------------------------- solver


def solve_pickplace(
    spec: SceneSpec[PickPlaceSpec], target_index: int, evaluator: SceneEvaluator
) -> PickPlaceOutcome:
    """One result of a pick-and-place scene: a target, a pair of unit targets, or the front.

    Result ``i`` is target ``i`` for ``i < len(targets)``, then the unit targets, then the
    difference objective (read by
    :func:`dpfexplore.inverse.scenes.pickplace.report.pickplace_report`).
    """
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    p = spec.kind_spec
    if target_index < len(p.targets):
        found = _solve_target(spec, target_index, evaluator, screen_pickplace(spec, evaluator))
    elif target_index < len(p.targets) + len(p.unit_targets):
        found = _solve_units(
            spec, target_index, evaluator, screen_pickplace(spec, evaluator, complete=True)
        )
    else:
        found = solve_difference(spec, target_index, evaluator, second_screen(spec, evaluator))
    best = found["best"]
    reachable = best is not None and (
        best.get("ok", False) if found["kind"] == "difference" else best["error"] <= p.tolerance
    )
    outcome = PickPlaceOutcome(
        target_index=target_index,
        kind=found["kind"],
        target=found["target"],
        best=best,
        reachable=bool(reachable),
        attempts=found.get("attempts", []),
        brackets=found.get("brackets", 0),
        units=found.get("units"),
        front=found.get("front", []),
        lines=found.get("lines", []),
        weighted=found.get("weighted"),
    )
    outcome.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    outcome.wall_s = evaluator.wall_s - wall0
    return outcome
