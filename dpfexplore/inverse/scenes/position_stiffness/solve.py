"""The position-and-stiffness scene's solver (paper eq. opti_pos_stiff).

Each target is met as in the position scene (:func:`~..position.solve.search_target`), from
every N where it is reachable; then the stiffness front grows from those exact solutions
(:func:`~dpfexplore.inverse.engine.optimiser.stiffness_front`: the stiffest design within each
tip tolerance) and, when the scene gives weights, the paper's weighted sum
``w1 |r|² + w2 (1/K)²`` is refined from the best design of every N and from every rung of the
front (the weighted optimum lies on the front's side of the trade-off).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...engine.optimiser import (
    ResidualRefinement,
    TargetResult,
    refine_residual,
    stiffness_front,
)
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from ..position.solve import search_target
from .spec import PositionStiffnessSpec

__all__ = ["solve_position_stiffness"]


def solve_position_stiffness(
    spec: SceneSpec[PositionStiffnessSpec], target_index: int, evaluator: SceneEvaluator
) -> TargetResult:
    """Meet one target, then its stiffness front and weighted sum (module docstring)."""
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    p = spec.kind_spec
    result = search_target(spec, target_index, evaluator, exhaustive=True)
    if result.reachable:
        met = [run for run in result.starts if run.objective <= p.tolerance]
        result.front = stiffness_front(met, p.front, max_iter=spec.optimiser.max_iter)
    if p.weights is not None and result.best is not None:
        seeds = [(r.problem, r.z) for r in _best_per_n(result.starts)]
        seeds += [(q.problem, q.z) for q in result.front if q.z is not None]
        runs = [
            refine_residual(
                problem, z, goal=0.0, max_iter=spec.optimiser.max_iter, weights=p.weights
            )
            for problem, z in seeds
        ]
        result.weighted = min(runs, key=lambda r: _weighted(r, p.weights))
    result.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    result.wall_s = evaluator.wall_s - wall0
    return result


def _weighted(run: ResidualRefinement, weights: tuple[float, float]) -> float:
    k = run.evaluation.stiffness[0]
    return weights[0] * run.objective + weights[1] / k**2 if np.isfinite(k) else np.inf


def _best_per_n(runs: Sequence[ResidualRefinement]) -> list[ResidualRefinement]:
    best: dict[int, ResidualRefinement] = {}
    for r in runs:
        n = r.problem.n_units
        if n not in best or r.objective < best[n].objective:
            best[n] = r
    return list(best.values())
