"""The gripper scene's solve with its sorting objective (the scene's ``solve`` entry).

Without ``[gripper.sorting]`` this is :func:`.solve.solve_gripper` and nothing else. With it,
the scene's own design comes first (apertures as ``[gripper]`` asks); then
:func:`.sorting_search.search_apertures` moves the apertures to widen the classes' margin, the
best point is stiffened by the scene's own stage with those apertures as targets (tip unit
metastable, pressure windows), and the stiffened design is kept if its margin, from the loop,
beats the scene's design's.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, fields, replace

import numpy as np

from ...engine.optimiser import ResidualRefinement
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .problem import GripperProblem
from .solve import (
    GripperTargetResult,
    _stiffen,
    gripper_problem,
    metastability,
    solve_gripper,
    windows_ok,
)
from .sorting_search import SortingSearch, gripper_at, loop_margins, search_apertures, tip_lasts
from .spec import GripperSpec
from .windows import pressure_windows

logger = logging.getLogger(__name__)

__all__ = ["SortingTargetResult", "solve_scene"]


@dataclass
class SortingTargetResult(GripperTargetResult):
    """The gripper's result with its sorting search.

    Attributes
    ----------
    sorting : SortingSearch or None
    apertures : tuple of float
        The target apertures of the reported design, mm (the search's, or the scene's).
    stiffened_margin : float
        The loop's margin of the search's best point once stiffened (NaN: not stiffened).
    """

    sorting: SortingSearch | None = None
    apertures: tuple[float, ...] = ()
    stiffened_margin: float = float("nan")


def _reference_start(problem: GripperProblem) -> list[np.ndarray]:
    """The scene's reference gripper as a box point, when it has one inside the box."""
    from ....model.design import DesignBatch

    g = problem.spec
    if g.reference is None or g.reference_theta_B_deg is None or g.reference_base_L is None:
        return []
    try:
        z, ok = problem.variables.encode(DesignBatch.from_designs([g.reference]), tol=1e-6)
    except ValueError:
        return []
    (t0, t1), (b0, b1) = g.theta_B_deg, g.base_L
    base = [
        (g.reference_theta_B_deg - t0) / (t1 - t0) if t1 > t0 else 0.0,
        (g.reference_base_L - b0) / (b1 - b0) if b1 > b0 else 0.0,
    ]
    if not bool(np.all(ok)) or not all(0.0 <= v <= 1.0 for v in base):
        return []
    return [np.concatenate([np.asarray(z[0], dtype=float), base])]


def _candidate_starts(problem: GripperProblem, spec: SceneSpec[GripperSpec]) -> list:
    """``starts_per_n`` distinct candidates of the scene's screen, fitted to its apertures."""
    from ...engine.optimiser import (
        GOAL_FRACTION,
        distinct_starts,
        latin_candidates,
        refine_residual,
    )
    from .solve import _screen

    settings = spec.optimiser
    zf = latin_candidates(problem.n_finger, settings.candidates_per_n, spec.seed + 1)
    candidates = _screen(problem, zf)
    goal = (GOAL_FRACTION * problem.spec.aperture_tol) ** 2
    out = []
    for i in distinct_starts(candidates, settings.starts_per_n):
        run = refine_residual(problem, candidates.z[i], goal=goal, max_iter=settings.max_iter)
        residual = run.evaluation.residual[0]
        if np.all(np.isfinite(residual)) and np.max(np.abs(residual)) <= problem.spec.aperture_tol:
            out.append(run.z)
    return out


def solve_scene(
    spec: SceneSpec[GripperSpec], target_index: int, evaluator: SceneEvaluator
) -> GripperTargetResult:
    """The gripper scene: :func:`.solve.solve_gripper`, then the sorting objective if any."""
    result = solve_gripper(spec, target_index, evaluator)
    g = spec.kind_spec
    if g.sorting is None:
        return result
    out = SortingTargetResult(
        **{f.name: getattr(result, f.name) for f in fields(GripperTargetResult)},
        apertures=tuple(g.apertures),
    )
    if result.best is None:
        return out
    counts0, wall0 = dict(evaluator.counts), evaluator.wall_s
    problem = gripper_problem(spec, evaluator)
    starts = [result.best.z]
    for z in [*_reference_start(problem), *_candidate_starts(problem, spec)]:
        if not any(np.allclose(z, other, rtol=0.0, atol=1e-9) for other in starts):
            starts.append(z)
    need_meta = bool(result.metastability.get("ok", False))
    need_windows = g.min_window_kPa > 0 and windows_ok(result.windows, g.min_window_kPa)

    def accept(fitted: GripperProblem, z: np.ndarray) -> bool:
        """The scene's checks that its own design passed, on the design at ``z``."""
        design = fitted.designs(np.atleast_2d(z)).design(0)
        if need_meta and not metastability(design, fitted.spec, evaluator)["ok"]:
            return False
        if need_windows:
            windows = pressure_windows(design, g.states, evaluator)
            return windows_ok(windows, g.min_window_kPa)
        return True

    search = search_apertures(
        problem,
        starts,
        g.sorting,
        evaluator,
        max_iter=spec.optimiser.max_iter,
        accept=accept,
    )
    out.sorting = search
    if search.best is not search.default and search.z is not None:
        fit = replace(g, apertures=search.apertures)
        fitted = GripperProblem(problem.variables, fit, evaluator)
        ev = fitted.evaluate(np.atleast_2d(search.z), purpose="refine", stiffness=True)
        start = ResidualRefinement(
            problem=fitted,
            z=search.z,
            evaluation=ev,
            objective=float(ev.objective[0]),
            iterations=0,
            reached=True,
        )
        design = fitted.designs(np.atleast_2d(search.z)).design(0)
        as_found = {"refinement": start, "checks": metastability(design, fit, evaluator)}
        as_found["band"] = result.alpha_band
        finalists = [as_found, _stiffen(fitted, start, evaluator, spec)]
        chosen = None
        for finalist in finalists:
            z = finalist["refinement"].z
            gripper = gripper_at(fitted, z)
            lasts = tip_lasts(gripper, g.sorting, evaluator)
            finalist["margin"] = loop_margins(gripper, g.sorting, lasts).margin
            finalist["windows"] = pressure_windows(gripper.design, g.states, evaluator)
            # a finalist wins only with a larger margin and the checks the scene's own design
            # passed (the tip unit metastable, the pressure windows)
            keep = finalist["margin"] > search.default.margin and (
                finalist["checks"].get("ok", False) or not result.metastability.get("ok", False)
            )
            if keep and g.min_window_kPa > 0 and windows_ok(result.windows, g.min_window_kPa):
                keep = windows_ok(finalist["windows"], g.min_window_kPa)
            if keep and (chosen is None or finalist["margin"] > chosen["margin"]):
                chosen = finalist
        out.stiffened_margin = finalists[1]["margin"]
        logger.info(
            "sorting: default margin %.4f, searched %.4f, stiffened %.4f (%s)",
            search.default.margin,
            finalists[0]["margin"],
            finalists[1]["margin"],
            "none kept" if chosen is None else f"kept {chosen['margin']:.4f}",
        )
        if chosen is not None:
            out.best = chosen["refinement"]
            out.metastability = chosen["checks"]
            out.alpha_band = chosen["band"]
            out.windows = chosen["windows"]
            out.apertures = tuple(search.apertures)
            out.reachable = True
    for k in evaluator.counts:
        out.counts[k] = out.counts.get(k, 0) + evaluator.counts[k] - counts0.get(k, 0)
    out.wall_s += evaluator.wall_s - wall0
    return out
