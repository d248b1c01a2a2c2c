"""Bounded least squares in the unit box that stops at a goal and keeps the best point.

The one local refiner of the package: inverse design's refinement of a scene's residual
(:func:`dpfexplore.inverse.engine.optimiser.refine_residual`) and lookup's polish of a dataset
design (:func:`dpfexplore.lookup.polish.refine`) both call :func:`least_squares_in_box`.

Method
    :func:`scipy.optimize.least_squares` with bounds ``[0, 1]^m``, run in one or more
    :class:`Stage` s, each from the same start, until one reaches the goal or the evaluation
    budget is spent. The residual function says where it has no value (a targeted state that
    does not exist at the point): that point gets a residual larger than any met so far, so the
    trust region rejects the step and shrinks, and the search goes on where the residual exists.
Guarantees
    The returned point is the best one evaluated (least ``|f|²`` among points with a residual),
    not SciPy's last iterate; the run ends at the first point with ``|f|² <= goal``; no more
    than ``max_nfev`` residual evaluations in total, the start included; the point ``x`` is
    never evaluated twice in a row (the last value is kept for SciPy's repeated calls).
Limits
    A local method: a start on the wrong side of a fold, or a local minimum of ``|f|``, ends
    above the goal (``status`` :data:`STOPPED`). The caller's Jacobian must be that of the
    residual it returns (no finite differences are taken here).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

__all__ = [
    "GOAL_MET",
    "NO_START",
    "STOPPED",
    "LocalResult",
    "Stage",
    "least_squares_in_box",
]

#: ``status`` of a run that reached ``|f|² <= goal``.
GOAL_MET = 1
#: ``status`` of a run that ended above the goal (SciPy's tolerances, the budget, or no goal).
STOPPED = 0
#: ``status`` of a run whose start has no residual (nothing was solved from it).
NO_START = -1


@dataclass(frozen=True)
class Stage:
    """One :func:`scipy.optimize.least_squares` run of a refinement.

    Attributes
    ----------
    method : {"trf", "dogbox"}
    tr_solver : {"exact", "lsmr"} or None
        SciPy's trust-region subproblem solver (None: SciPy's choice). ``"lsmr"`` needs two
        variables: with one, ``"exact"`` is used.
    max_nfev : int or None
        Evaluations this stage may use (None: the rest of the budget).
    """

    method: str = "trf"
    tr_solver: str | None = None
    max_nfev: int | None = None


@dataclass(frozen=True)
class LocalResult:
    """Outcome of :func:`least_squares_in_box`, named as :class:`scipy.optimize.OptimizeResult`.

    Attributes
    ----------
    x : ndarray of shape (m,)
        The best point evaluated (the clipped start if the start has no residual).
    fun : ndarray of shape (d,) or None
        The residual at ``x`` (None if the start has no residual).
    objective : float
        ``|fun|²`` (inf without a residual).
    info : object
        What the residual function returned with ``fun`` at ``x`` (the caller's evaluation).
    success : bool
        ``status`` is :data:`GOAL_MET`, or, without a goal, the start has a residual.
    status : int
        :data:`GOAL_MET`, :data:`STOPPED` or :data:`NO_START`.
    message : str
        What stopped it (SciPy's message of each stage, or the goal).
    nfev : int
        Residual evaluations (the start included; SciPy's repeated calls at one point not).
    njev : int
        Jacobian evaluations.
    failures : int
        Evaluated points without a residual.
    """

    x: NDArray
    fun: NDArray | None
    objective: float
    info: Any
    success: bool
    status: int
    message: str
    nfev: int
    njev: int
    failures: int


class _GoalMet(Exception):
    """Raised from the residual to end the run at the first point that meets the goal."""


class _Run:
    """The residual seen by SciPy, with the best point, the counts and the last value."""

    def __init__(self, fun: Callable, jac: Callable, n_residuals: int | None, goal) -> None:
        self.user_fun, self.user_jac, self.goal = fun, jac, goal
        self.n_residuals = n_residuals
        self.nfev = self.njev = self.failures = 0
        self.best_x: NDArray | None = None
        self.best_f: NDArray | None = None
        self.best_info: Any = None
        self.best = np.inf
        # Stands in for a missing residual: larger than any residual met so far.
        self.penalty = 1.0
        self.last: tuple[NDArray, NDArray] | None = None
        self.start_info: Any = None

    def fun(self, x: NDArray) -> NDArray | None:
        if self.last is not None and np.array_equal(self.last[0], x):
            return self.last[1]
        x = x.copy()
        f, info = self.user_fun(x)
        self.nfev += 1
        if self.nfev == 1:
            self.start_info = info
        if f is None:
            self.failures += 1
            if self.n_residuals is None:  # the start: the run ends
                return None
            f = np.full(self.n_residuals, self.penalty)
        else:
            f = np.asarray(f, dtype=float)
            self.n_residuals = f.size
            value = float(f @ f)
            self.penalty = max(self.penalty, 10.0 * (np.sqrt(value) + 1.0))
            if value < self.best:
                self.best, self.best_x, self.best_f, self.best_info = value, x, f, info
            if self.goal is not None and value <= self.goal:
                self.last = (x, f)
                raise _GoalMet
        self.last = (x, f)
        return f

    def jac(self, x: NDArray) -> NDArray:
        self.njev += 1
        return self.user_jac(x.copy())


def least_squares_in_box(
    fun: Callable[[NDArray], tuple[NDArray | None, Any]],
    x0: ArrayLike,
    *,
    jac: Callable[[NDArray], NDArray],
    max_nfev: int,
    goal: float | None = None,
    stages: Sequence[Stage] = (Stage(),),
    ftol: float = 1e-8,
    xtol: float = 1e-8,
    gtol: float = 1e-8,
) -> LocalResult:
    """Minimise ``|fun(x)|²`` over ``x ∈ [0, 1]^m`` from ``x0``, stopping once at most ``goal``.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (f, info)``: the residual, ndarray of shape (d,), or None where it has no
        value, and any object to keep with it (returned as ``info`` for the best point).
    x0 : array_like of shape (m,)
        Start (clipped to the box).
    jac : callable
        ``jac(x) -> ndarray of shape (d, m)``, ``∂f/∂x``; called only at points with a residual.
    max_nfev : int
        Residual evaluations in total, the start included.
    goal : float, optional
        Stop at the first point with ``|f|² <= goal`` (default: no early stop).
    stages : sequence of Stage
        SciPy runs, each from ``x0``, until the goal is met or the budget is spent.
    ftol, xtol, gtol : float
        SciPy's tolerances, for every stage.

    Returns
    -------
    LocalResult
        The best point evaluated and the counts.

    Raises
    ------
    ValueError
        ``max_nfev < 1``, an unknown stage method, or ``x0`` that is not one finite vector.
    """
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 = {x0!r}: need one finite vector")
    if max_nfev < 1:
        raise ValueError(f"max_nfev = {max_nfev!r}: must be at least 1")
    for stage in stages:
        if stage.method not in ("trf", "dogbox"):
            raise ValueError(f"stage method = {stage.method!r}: choose 'trf' or 'dogbox'")
    x0 = np.clip(x0, 0.0, 1.0)
    run = _Run(fun, jac, None, goal)
    messages: list[str] = []

    def result(status: int, message: str) -> LocalResult:
        if run.best_x is None:
            return LocalResult(
                x=x0, fun=None, objective=np.inf, info=run.start_info, success=False,
                status=NO_START, message=message, nfev=run.nfev, njev=run.njev,
                failures=run.failures,
            )  # fmt: skip
        return LocalResult(
            x=run.best_x,
            fun=run.best_f,
            objective=run.best,
            info=run.best_info,
            success=status == GOAL_MET or (goal is None and status == STOPPED),
            status=status,
            message=message,
            nfev=run.nfev,
            njev=run.njev,
            failures=run.failures,
        )

    # The start is evaluated first: a start without a residual ends the run, and SciPy's first
    # call (the same point) reuses the value.
    try:
        if run.fun(x0) is None:
            return result(NO_START, "no residual at the start")
    except _GoalMet:
        return result(GOAL_MET, "the start meets the goal")
    if x0.size == 0:
        return result(STOPPED, "no free variables")
    try:
        for stage in stages:
            tr_solver = stage.tr_solver
            if tr_solver == "lsmr" and x0.size == 1:
                tr_solver = "exact"  # SciPy's LSMR path needs two variables
            budget = max_nfev - run.nfev
            budget = budget if stage.max_nfev is None else min(stage.max_nfev, budget)
            if budget <= 0:
                break
            # SciPy counts its first call, which is free when the start is the last point (trf
            # first moves a start on a bound inside the box, to a point not yet evaluated).
            free = run.last is not None and np.array_equal(run.last[0], x0)
            if stage.method == "trf":
                free = free and bool(np.all((x0 > 0.0) & (x0 < 1.0)))
            out = least_squares(
                run.fun,
                x0,
                jac=run.jac,
                bounds=(0.0, 1.0),
                method=stage.method,
                tr_solver=tr_solver,
                x_scale=1.0,
                ftol=ftol,
                xtol=xtol,
                gtol=gtol,
                max_nfev=budget + int(free),
            )
            messages.append(f"{stage.method}: {out.message}")
    except _GoalMet:
        return result(GOAL_MET, f"goal met (|f|² = {run.best:.3g})")
    return result(STOPPED, "; ".join(messages) or "no evaluations left")
