"""The multi-target optimiser of inverse design, built for this model.

Method
------
1. **Candidates for every N at once.** A Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`)
   in the box ``z ∈ [0, 1]^dim`` of each number of units, mapped to designs by
   :class:`~dpfexplore.model.variables.DesignVariables` (so every candidate honours the bounds,
   orders, ties and shared parameters exactly), solved in one batch across all N; or, when the
   scene names a sweep dataset (``[optimiser] seeds``), the dataset's designs nearest the target
   (:mod:`dpfexplore.inverse.engine.seeds`: the lookup index, no model evaluation).
2. **Gradient refinement on the exact model.** From the best candidates of each N, a bounded
   trust-region least-squares solve (:func:`scipy.optimize.least_squares`, TRF, bounds = the box)
   of the residual (tip minus target, apertures minus targets) with the design sensitivities of
   :mod:`dpfexplore.inverse.engine.derivatives`. The constraints are never penalised: they are the
   box. A trial point whose targeted state does not exist (the design collapses to another state)
   has no residual; the trust region shrinks and the step is retried.
3. **Two objectives as a front.** Stiffness against tip tolerance: for each tolerance of a
   ladder, maximise ``log K`` subject to ``|tip - target| <= tol`` by SLSQP on the exact
   gradients, warm-started from the previous (tighter) rung, from every N where the target is
   reachable. The answer at each rung is the stiffest exactly evaluated design that meets it.
   The paper's weighted sum ``w1 |r|² + w2 (1/K)²`` is a least-squares problem too
   (residual ``[√w1 r, √w2 / K]``) and is solved by step 2.
4. **Unreachable targets are proven, not guessed.** A target is declared unreachable only when
   ``starts_per_n`` refinements from the best distinct candidates of every N all stop above the
   tolerance (:func:`~.distinct_starts`; the position scenes' rounds are in
   :mod:`dpfexplore.inverse.scenes.position.solve`); the report gives the nearest tip found and
   the tips of every evaluated design (the sampled reachable region) per N.

The engine imports no scene and reads no kind: a scene kind's solver (in its package under
:mod:`dpfexplore.inverse.scenes`) builds its :class:`~.problem.Problem` objects and drives these
steps with its own tolerances and budget (:class:`~.settings.OptimiserSettings`).
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize
from scipy.stats import qmc

from ...model.design import DesignBatch
from ...numerics.local import least_squares_in_box
from ..evaluation import SceneEvaluator
from .problem import Evaluation, Problem
from .seeds import seed_candidates
from .settings import OptimiserSettings

__all__ = [
    "FrontPoint",
    "ResidualRefinement",
    "TargetResult",
    "candidates",
    "distinct_starts",
    "latin_candidates",
    "maximise_stiffness",
    "refine_residual",
    "screen",
    "stiffness_front",
]

logger = logging.getLogger(__name__)

#: Refinements stop once the objective is this fraction of the tolerance (a margin for the
#: verification re-solve).
GOAL_FRACTION = 1e-3
#: A refinement whose squared residual falls by less than this fraction in an iteration has
#: settled in a local minimum above the goal (a zero-residual solve converges quadratically, so
#: this never stops one that is reaching its target).
FTOL = 1e-4
#: A short first refinement that ends within this squared distance (mm²) is continued at once.
PROMISING = 1e-2
#: Exact position solutions (the stiffest ones) that a stiffness front is grown from.
FRONT_STARTS = 3


@dataclass(eq=False)
class ResidualRefinement:
    """Outcome of one gradient refinement."""

    problem: Problem
    z: NDArray
    evaluation: Evaluation
    objective: float
    iterations: int
    reached: bool


@dataclass
class FrontPoint:
    """The stiffest design found within one tip tolerance (mm)."""

    tolerance: float
    z: NDArray | None
    problem: Problem | None
    distance: float
    stiffness: float


@dataclass
class TargetResult:
    """Everything the optimiser found for one target (before verification and reporting).

    Attributes
    ----------
    target_index : int
    target : tuple of float
        The target (tip, mm; apertures, mm).
    best : ResidualRefinement or None
        The best point found (the nearest one when the target is out of reach).
    reachable : bool
    per_n : dict of int to float
        Best objective (mm²) per number of units.
    starts : list of ResidualRefinement
        Every refinement run.
    front : list of FrontPoint
        The stiffness front, when one was grown.
    weighted : ResidualRefinement or None
        The weighted-sum optimum, when asked.
    counts : dict of str to int
        Evaluations of this target by kind.
    wall_s : float
        Seconds spent on this target.
    """

    target_index: int
    target: tuple[float, ...]
    best: ResidualRefinement | None
    reachable: bool
    per_n: dict[int, float] = field(default_factory=dict)
    starts: list[ResidualRefinement] = field(default_factory=list)
    front: list[FrontPoint] = field(default_factory=list)
    weighted: ResidualRefinement | None = None
    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0


# ----------------------------------------------------------------------------- candidates


def latin_candidates(dim: int, n: int, seed: int) -> NDArray:
    """``n`` Latin-hypercube points in ``[0, 1]^dim`` (an empty row for ``dim = 0``)."""
    if dim == 0:
        return np.zeros((1, 0))
    return qmc.LatinHypercube(d=dim, rng=np.random.default_rng(seed)).random(n)


def screen(
    problems: Sequence[Problem], points: Sequence[NDArray], *, stiffness: bool = False
) -> list[Evaluation]:
    """Evaluate points of several problems (e.g. every N) in one batch of the exact model."""
    requests = [p.requests(z, stiffness=stiffness) for p, z in zip(problems, points, strict=True)]
    n_states = {r[1].size for r in requests}
    if len(n_states) != 1:  # different state counts: one call per problem
        return [
            p.evaluate(z, purpose="candidate", stiffness=stiffness)
            for p, z in zip(problems, points, strict=True)
        ]
    batch = DesignBatch.concatenate([r[0] for r in requests])
    states = np.vstack([np.broadcast_to(r[1], (len(r[0]), r[1].size)) for r in requests])
    want = requests[0][2]
    evaluator = problems[0].evaluator
    out = evaluator.solve(batch, states, stiffness=want)
    evaluator.report("screening candidates", len(batch), len(batch))
    evaluations, start = [], 0
    for p, z, (b, _, _) in zip(problems, points, requests, strict=True):
        part = {k: v[start : start + len(b)] for k, v in out.items()}
        ev = p.finish(z, b, part)
        p.record(b, ev, "candidate")
        evaluations.append(ev)
        start += len(b)
    return evaluations


def candidates(
    problems: Sequence[Problem],
    settings: OptimiserSettings,
    seed: int,
    evaluator: SceneEvaluator,
) -> list[Evaluation]:
    """Candidates of every N: the dataset seeds of ``settings``, else a screened Latin hypercube.

    Seeding needs problems with a tip target (:class:`~.seeds.SeedableProblem`). The N a seeds
    dataset lacks (or settings without one) get the Latin hypercube of
    ``settings.candidates_per_n`` points (seeded by ``seed`` and N), screened in one batch.
    """
    seeded: list[Evaluation | None] = [None] * len(problems)
    if settings.seeds is not None:
        seeded = seed_candidates(list(problems), settings.seeds, settings.seeds_per_n, evaluator)
    missing = [i for i, ev in enumerate(seeded) if ev is None]
    points = [
        latin_candidates(
            problems[i].dim, settings.candidates_per_n, seed + 7919 * problems[i].n_units
        )
        for i in missing
    ]
    for i, ev in zip(missing, screen([problems[i] for i in missing], points), strict=True):
        seeded[i] = ev
    return seeded  # type: ignore[return-value]


def distinct_starts(ev: Evaluation, count: int, *, min_gap: float = 0.15) -> list[int]:
    """Indices of up to ``count`` best feasible candidates, at least ``min_gap`` apart in z."""
    order = np.argsort(ev.objective)
    chosen: list[int] = []
    for i in order:
        if not np.isfinite(ev.objective[i]):
            break
        if all(np.max(np.abs(ev.z[i] - ev.z[j])) >= min_gap for j in chosen):
            chosen.append(int(i))
        if len(chosen) == count:
            break
    return chosen


# ----------------------------------------------------------------------------- refinement


def refine_residual(
    problem: Problem,
    z0: NDArray,
    *,
    goal: float,
    max_iter: int,
    weights: tuple[float, float] | None = None,
) -> ResidualRefinement:
    """Least-squares refinement (TRF in the box) of a problem's residual from ``z0``.

    :func:`~dpfexplore.numerics.local.least_squares_in_box` on the residual (tip minus target,
    apertures minus targets) with the exact design sensitivities of the problem.

    Parameters
    ----------
    problem : Problem
    z0 : ndarray of shape (dim,)
        A point whose targeted states exist.
    goal : float, mm²
        Stop as soon as the squared residual is at most this.
    max_iter : int
        Residual evaluations allowed (each with its derivative stencil).
    weights : (w1, w2), optional
        Solve the paper's weighted sum ``w1 |r|² + w2 (1/K)²`` instead (no early stop).

    Returns
    -------
    ResidualRefinement
        The best exactly evaluated point of the run.
    """
    stiffness = weights is not None
    last: dict = {"n": 0}
    budget = max(int(max_iter), 1)

    def fun(z: NDArray) -> tuple[NDArray | None, Evaluation]:
        ev = problem.evaluate(z[None, :], purpose="refine", stiffness=stiffness)
        last["z"], last["ev"] = z, ev
        last["n"] += 1
        problem.evaluator.report("refining", last["n"], max(last["n"], budget))
        if not ev.ok[0]:
            return None, ev
        r = ev.residual[0]
        if stiffness:
            w1, w2 = weights
            return np.append(math.sqrt(w1) * r, math.sqrt(w2) / ev.stiffness[0]), ev
        return r, ev

    def jac(z: NDArray) -> NDArray:
        ev = last["ev"] if last.get("z") is not None and np.array_equal(last["z"], z) else None
        if ev is None or not ev.ok[0]:
            ev = problem.evaluate(z[None, :], purpose="refine", stiffness=stiffness)
        d_res, d_logk = problem.jacobian(ev, stiffness=stiffness)
        if not stiffness:
            return d_res
        w1, w2 = weights
        return np.vstack([math.sqrt(w1) * d_res, -math.sqrt(w2) / ev.stiffness[0] * d_logk])

    run = least_squares_in_box(
        fun,
        z0,
        jac=jac,
        max_nfev=budget,
        goal=None if stiffness else goal,
        ftol=FTOL,
        xtol=1e-12,
        gtol=1e-15,
    )
    ev = run.info
    objective = float(ev.objective[0])
    return ResidualRefinement(
        problem=problem,
        z=run.x,
        evaluation=ev,
        objective=objective,
        iterations=run.nfev,
        reached=objective <= goal,
    )


# ----------------------------------------------------------------------------- front


def maximise_stiffness(
    problem: Problem,
    z0: NDArray,
    tolerance: float,
    *,
    max_iter: int,
    extra_constraints: Sequence[dict] = (),
) -> tuple[NDArray | None, Evaluation | None]:
    """Stiffest design with ``|residual| <= tolerance`` (mm) near ``z0``, by SLSQP.

    The residual constraint is ``1 - |r|²/tol² >= 0`` (scaled so every rung of a front is
    conditioned alike), the objective ``-log K``; both with exact-model derivatives. Returns the
    stiffest exactly evaluated point that meets the tolerance (it may be ``z0`` itself), or
    ``None`` when no evaluated point met it.
    """
    tol2 = tolerance**2
    best: dict = {"k": -np.inf, "z": None, "ev": None}
    cache: dict = {}
    calls = [0]

    def at(z: NDArray) -> Evaluation:
        z = np.clip(z, 0.0, 1.0)
        key = z.tobytes()
        if key not in cache:
            ev = problem.evaluate(z[None, :], purpose="front", stiffness=True)
            cache.clear()
            cache[key] = ev
            calls[0] += 1  # SLSQP's evaluations, against its iteration budget
            problem.evaluator.report(
                "stiffest design within the tolerance", calls[0], max(calls[0], max_iter)
            )
            # SLSQP meets active constraints to rounding: a relative slack of 1e-9 accepts its
            # end point without moving a reported design measurably.
            if (
                ev.ok[0]
                and ev.objective[0] <= tol2 * (1 + 1e-9)
                and ev.stiffness[0] > best["k"]
                and all(c["fun"](z) >= -1e-9 for c in extra_constraints)
            ):
                best.update(k=float(ev.stiffness[0]), z=z.copy(), ev=ev)
        return cache[key]

    def grads(z: NDArray) -> tuple[NDArray, NDArray]:
        ev = at(z)
        key = ("jac", np.clip(z, 0.0, 1.0).tobytes())
        if key not in cache:
            cache[key] = (
                problem.jacobian(ev, stiffness=True)
                if ev.ok[0]
                else (np.zeros((problem.n_residuals, problem.dim)), np.zeros(problem.dim))
            )
        return cache[key]

    def objective(z: NDArray) -> float:
        ev = at(z)
        return -math.log(ev.stiffness[0]) if ev.ok[0] else 50.0

    def objective_grad(z: NDArray) -> NDArray:
        return -grads(z)[1]

    def constraint(z: NDArray) -> float:
        ev = at(z)
        return 1.0 - float(ev.objective[0]) / tol2 if ev.ok[0] else -1.0

    def constraint_grad(z: NDArray) -> NDArray:
        ev = at(z)
        if not ev.ok[0]:
            return np.zeros(problem.dim)
        return -2.0 * ev.residual[0] @ grads(z)[0] / tol2

    at(z0)
    if problem.dim:
        out = minimize(
            objective,
            np.clip(z0, 0.0, 1.0),
            jac=objective_grad,
            method="SLSQP",
            bounds=[(0.0, 1.0)] * problem.dim,
            constraints=[
                {"type": "ineq", "fun": constraint, "jac": constraint_grad},
                *extra_constraints,
            ],
            options={"maxiter": max_iter, "ftol": 1e-10},
        )
        logger.debug("SLSQP: %s after %d iterations", out.message, out.nit)
    return best["z"], best["ev"]


def stiffness_front(
    met: Sequence[ResidualRefinement], rungs: Sequence[float], *, max_iter: int
) -> list[FrontPoint]:
    """Stiffness against tip tolerance, grown from exact solutions of a target.

    ``met`` are refinements that met the target (of every N where it was met), ``rungs`` the
    tip tolerances (mm, ascending) and ``max_iter`` the SLSQP iterations per rung. The front
    grows from the :data:`FRONT_STARTS` stiffest of ``met``, rung to rung. Each rung is
    answered by the stiffest of *all* designs evaluated with their stiffness on the way (every
    SLSQP iterate, line-search point and derivative stencil point is an exact evaluation), not
    only by the end point of its own SLSQP run; so a looser rung is never less stiff than a
    tighter one.
    """
    # The front grows from the stiffest exact solutions (one stiffness solve each).
    stiffness = [
        float(r.problem.evaluate(r.z[None, :], purpose="front", stiffness=True).stiffness[0])
        for r in met
    ]
    order = np.argsort(-np.nan_to_num(np.array(stiffness), nan=-np.inf))
    met = [met[i] for i in order[:FRONT_STARTS]]
    problems = {id(run.problem): run.problem for run in met}
    front = [FrontPoint(tol, None, None, np.inf, -np.inf) for tol in rungs]
    if not met:
        return front
    evaluators = {id(p.evaluator): p.evaluator for p in problems.values()}
    with contextlib.ExitStack() as stack:
        archives: dict[int, list] = {}
        for evaluator in evaluators.values():
            mine = [p for p in problems.values() if p.evaluator is evaluator]
            archives.update(stack.enter_context(evaluator.archiving(mine)))
        for run in met:
            z = run.z
            for tol in rungs:
                z_new, _ = maximise_stiffness(run.problem, z, tol, max_iter=max_iter)
                if z_new is not None:
                    z = z_new
    for key, problem in problems.items():
        for objective, stiffness, z in archives[key]:
            ok = np.isfinite(objective) & np.isfinite(stiffness)
            for point in front:
                inside = ok & (objective <= point.tolerance**2)
                if not np.any(inside):
                    continue
                i = int(np.argmax(np.where(inside, stiffness, -np.inf)))
                if stiffness[i] > point.stiffness:
                    point.z, point.problem = z[i].copy(), problem
                    point.stiffness = float(stiffness[i])
                    point.distance = math.sqrt(float(objective[i]))
    return front
