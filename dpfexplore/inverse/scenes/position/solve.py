"""The position scene's solver: one target, every N (paper eq. opti_pos).

Method
------
The steps of :mod:`dpfexplore.inverse.engine.optimiser`: candidates for every N at once (a
Latin hypercube, or a seeds dataset's nearest tips), then rounds of refinement: first a short
one from the best start of every N (most reachable targets are met there), then that refinement
continued with the full budget from the N nearest the target first, then the further starts.
A target is declared unreachable only when ``starts_per_n`` refinements of every N stop above
the tolerance; the nearest tip of any evaluated design is then reported.
"""

from __future__ import annotations

import numpy as np

from ...engine.optimiser import (
    GOAL_FRACTION,
    PROMISING,
    ResidualRefinement,
    TargetResult,
    distinct_starts,
    refine_residual,
)
from ...engine.optimiser import candidates as engine_candidates
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .problem import PositionProblem
from .spec import PositionSpec

__all__ = ["position_problems", "search_target", "solve_position_target"]


def position_problems(
    spec: SceneSpec[PositionSpec], target_index: int, evaluator: SceneEvaluator
) -> list[PositionProblem]:
    """One problem per N of the scene for one target."""
    p = spec.kind_spec
    target = p.targets[target_index].point
    return [
        PositionProblem(spec.design_variables(n), target, p.state, evaluator, target_index)
        for n in spec.n_units
    ]


def solve_position_target(
    spec: SceneSpec[PositionSpec], target_index: int, evaluator: SceneEvaluator
) -> TargetResult:
    """Meet one target of a position scene, with its evaluations and wall time."""
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    result = search_target(spec, target_index, evaluator)
    result.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    result.wall_s = evaluator.wall_s - wall0
    return result


def search_target(
    spec: SceneSpec[PositionSpec],
    target_index: int,
    evaluator: SceneEvaluator,
    *,
    exhaustive: bool = False,
) -> TargetResult:
    """Meet one target of a position-shaped scene (module docstring); counts left unset.

    Parameters
    ----------
    spec : SceneSpec
    target_index : int
    evaluator : SceneEvaluator
    exhaustive : bool
        Refine from every N even after the target is met (a front needs every N where the
        target is reachable).
    """
    p = spec.kind_spec
    problems = position_problems(spec, target_index, evaluator)
    settings = spec.optimiser
    goal = GOAL_FRACTION * p.tolerance
    candidates = engine_candidates(problems, settings, spec.seed, evaluator)
    starts = {
        q.n_units: distinct_starts(ev, settings.starts_per_n)
        for q, ev in zip(problems, candidates, strict=True)
    }
    best_candidate = {
        q.n_units: float(np.min(ev.objective)) for q, ev in zip(problems, candidates, strict=True)
    }
    order = sorted(range(len(problems)), key=lambda i: best_candidate[problems[i].n_units])
    result = TargetResult(
        target_index=target_index,
        target=p.targets[target_index].point,
        best=None,
        reachable=False,
        per_n={n: v for n, v in best_candidate.items()},
    )
    reached_n: set[int] = set()
    # Rounds: first a short refinement from the best start of every N (most reachable targets
    # are met there), then that refinement continued with the full budget from the N nearest
    # the target first, then the further starts.
    quick = max(8, settings.max_iter // 5)
    plan = [(0, quick, False), (0, settings.max_iter, True)]
    plan += [(k, settings.max_iter, False) for k in range(1, settings.starts_per_n)]
    last: dict[int, ResidualRefinement] = {}
    for start, budget, resume in plan:
        if resume:
            order = sorted(order, key=lambda i: result.per_n[problems[i].n_units])
        for i in order:
            problem, ev = problems[i], candidates[i]
            n = problem.n_units
            if n in reached_n or start >= len(starts[n]):
                continue
            z0 = last[n].z if resume and n in last else ev.z[starts[n][start]]
            run = refine_residual(problem, z0, goal=goal, max_iter=budget)
            if not resume and budget < settings.max_iter and goal < run.objective <= PROMISING:
                # Converging on this N: finish here rather than after the other N.
                run = refine_residual(problem, run.z, goal=goal, max_iter=settings.max_iter)
            if resume and n in last:  # the continued run replaces the short one
                slot = next(j for j, r in enumerate(result.starts) if r is last[n])
                result.starts[slot] = run
            else:
                result.starts.append(run)
            last[n] = run
            result.per_n[n] = min(result.per_n[n], run.objective)
            if result.best is None or run.objective < result.best.objective:
                result.best = run
            if run.objective <= p.tolerance:
                reached_n.add(n)
                if not exhaustive:
                    break
        if reached_n and not exhaustive:
            break
    result.reachable = result.best is not None and result.best.objective <= p.tolerance
    if not result.reachable:
        # The nearest tip of any evaluated design (derivative stencils included).
        problem = min(problems, key=lambda q: q.evaluator.best_seen(q)[0])
        objective, z = problem.evaluator.best_seen(problem)
        if z is not None and (result.best is None or objective < result.best.objective):
            ev = problem.evaluate(z[None, :], purpose="nearest")
            result.best = ResidualRefinement(problem, z, ev, float(ev.objective[0]), 0, False)
        for q in problems:
            result.per_n[q.n_units] = min(result.per_n[q.n_units], q.evaluator.best_seen(q)[0])
    if result.best is None:  # no design had the targeted state: report the best candidate
        i = order[0]
        j = int(np.argmin(candidates[i].objective))
        result.best = ResidualRefinement(
            problems[i],
            candidates[i].z[j],
            candidates[i],
            float(candidates[i].objective[j]),
            0,
            False,
        )
    return result
