"""The sorting objective's search: the apertures that give the object classes the largest margin.

Method
------
The margin (:func:`dpfexplore.grasping.classes.class_margins`) is computed by the sorting loop
itself on the gripper of a box point (:func:`dpfexplore.grasping.gripper_of` on its base). It is
a minimum over classes of distances to boundaries located on the loop: piecewise smooth at best,
and flat where a class sits deep inside its region. So the search is derivative-free, over the
variables the scene already fits exactly: the target apertures of the grasp states.

1. **Starts.** The scene's own design (apertures as ``[gripper]`` asks, stiffened, tip unit
   metastable): its margin is the one to beat; the scene's reference gripper, if it gives one;
   and ``starts_per_n`` distinct Latin-hypercube candidates of the scene fitted to the
   ``[gripper]`` apertures. The finger's stiffness decides how far above a boundary a state
   still holds an object before the object pushes a dome back, so the start matters as much
   as the apertures. The best start's margin begins the search.
2. **Secant steps.** Each state's lower size boundary follows its aperture nearly one for one,
   so the apertures move by the distance from each boundary to a point just below its class
   (:func:`_secant`), in four trials of a quarter, a third, a half and all of what remains.
3. **Nelder-Mead** (:func:`scipy.optimize.minimize`) on the apertures from the best point, the
   initial simplex 2 mm along each aperture, until ``max_evaluations`` margins have been
   computed: it needs no derivative and moves several apertures at once, which a margin that
   is the smallest of the classes' needs (moving one boundary helps one class at a time).

A point becomes the best only if the scene's checks pass on it as they passed on the scene's own
design (the tip unit metastable under the pulse, a full-model run; the pressure windows, the
snap continuation): a fit moves the finger's lengths and heights, which both depend on.
Each trial's apertures are realised by the engine's trust-region least squares
(:func:`~dpfexplore.inverse.engine.optimiser.refine_residual`) from the best point so far, to
within half the aperture tolerance, on every variable but the tip unit's dome (its height and
the shared thickness ``t``, held at the best start's: that dome's isolated ``α`` decides
whether the tip unit is metastable, which the start passed); a trial it cannot realise is
skipped. The search assumes the tip unit lasts the lift as the start design's does (a reset
time is a simulation). The best point is then handed to the scene's stiffening stage
(:func:`.solve._stiffen`: stiffness, the tip unit metastable, the pressure windows) with its
apertures as targets, and both it and the stiffened design are checked again (margin with
their own tip reset time, the scene's checks): the one with the larger margin that passes the
checks the scene's own design passed is the answer, else the scene's own design, so the margin
found is never below the scene's default design's.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from ....grasping.classes import SortingMargins, class_margins
from ....grasping.grasp import tip_reset_time
from ....grasping.setup import Gripper, gripper_of
from ...engine.optimiser import ResidualRefinement, refine_residual
from ...evaluation import SceneEvaluator
from .problem import GripperProblem
from .sorting import SortingSpec

logger = logging.getLogger(__name__)

__all__ = ["SortingSearch", "gripper_at", "loop_margins", "search_apertures"]

#: A trial's fit stops once its apertures are within this fraction of the tolerance (the
#: scene's own fits go to GOAL_FRACTION; a trial is kept within half the tolerance).
TRIAL_GOAL = 0.1
#: The secant move, in fractions of what remains of it, each trial from the last point kept:
#: a fit that moves the apertures by millimetres at once can leave the tip unit's
#: metastability behind, one in steps follows it.
SECANT_STEPS = (0.25, 1.0 / 3.0, 0.5, 1.0)
#: Edge of the initial simplex along each aperture, mm.
SIMPLEX_MM = 2.0


@dataclass
class SortingSearch:
    """What the aperture search found.

    Attributes
    ----------
    default : SortingMargins or None
        The margins of the scene's own design (None: its gripper could not be built).
    best : SortingMargins or None
        The margins of the best point of the search (before stiffening).
    apertures : tuple of float
        The best point's target apertures, mm.
    z : ndarray or None
        The best point (box coordinates).
    evaluations : int
        Margins computed.
    trace : list of (apertures, margin)
        Every trial: apertures (mm) and margin (NaN: not realised, or refused by the checks).
    refused : int
        Trials with a larger margin that the scene's checks refused.
    """

    default: SortingMargins | None
    best: SortingMargins | None
    apertures: tuple[float, ...]
    z: NDArray | None
    evaluations: int = 0
    trace: list[tuple[list[float], float]] = field(default_factory=list)
    refused: int = 0


def gripper_at(problem: GripperProblem, z: NDArray) -> Gripper:
    """The gripper (finger and base) of box point ``z``, solved in its grasp states."""
    design = problem.designs(np.atleast_2d(z)).design(0)
    theta, base = problem.base(np.atleast_2d(z))
    return gripper_of(design, base_L=float(base[0]), theta_B_deg=float(theta[0]))


def loop_margins(gripper: Gripper, sorting: SortingSpec, tip_lasts: bool) -> SortingMargins:
    """The classes' margins of ``gripper`` by the loop (:func:`~.classes.class_margins`)."""
    return class_margins(
        gripper,
        sorting.classes,
        mu=sorting.mu,
        tip_lasts=tip_lasts,
        diameter_scale=sorting.diameter_scale_mm,
        mass_scale=sorting.mass_scale_kg,
    )


def tip_lasts(gripper: Gripper, sorting: SortingSpec, evaluator: SceneEvaluator) -> bool:
    """Whether the tip unit, inverted by its pulse, lasts ``lift_s`` (as ``sort`` decides)."""
    evaluator.count("simulations")
    return bool(tip_reset_time(gripper.design) >= sorting.lift_s)


def _secant(margins: SortingMargins, sorting: SortingSpec, apertures: NDArray) -> NDArray:
    """Apertures that move each state's lower size boundary just below its class.

    With as many classes as grasp states, class ``j`` (largest first) is state ``j``'s; its
    lower boundary (the ``j``-th, largest first) goes one class width and one diameter scale
    below the class, or to the middle of the gap below it if that is nearer (for the smallest
    class, the gap above it): a state holds an object only up to some millimetres above its
    boundary, beyond which the object pushes a dome back. Otherwise, or when the boundaries
    are not one per state, the apertures stay.
    """
    classes = sorting.classes  # largest first
    bounds = margins.boundaries_mm
    out = apertures.copy()
    if len(classes) != len(apertures) or len(bounds) != len(apertures) or len(classes) < 2:
        return out
    for j, c in enumerate(classes):
        (d_lo, d_hi) = c.diameter
        if j + 1 < len(classes):
            half_gap = 0.5 * (d_lo - classes[j + 1].diameter[1])
        else:
            half_gap = 0.5 * (classes[j - 1].diameter[0] - d_hi)
        below = min(half_gap, d_hi - d_lo + sorting.diameter_scale_mm)
        out[j] += d_lo - below - bounds[j]
    return out


def _domes_held(problem: GripperProblem, z: NDArray):
    """The problem's variables with the tip unit's dome (its ``H``, and ``t``) held at ``z``'s.

    Returns the held variables and the maps of box points from the full box to the held one
    and back (finger variables, then ``θ_B``, ``Base_L``).
    """
    from ....model.design import DesignBatch

    design = problem.designs(np.atleast_2d(z)).design(0)
    heights = problem.variables.H
    k = problem.spec.metastable_unit - 1
    held = [float(design.H[k]) if i == k else h for i, h in enumerate(heights)]
    frozen = replace(problem.variables, H=tuple(held), t=float(design.t))
    n_full, n_held = problem.n_finger, frozen.n_variables

    def convert(z: NDArray, source, target, n_source: int) -> NDArray:
        batch = DesignBatch.from_designs([source.design(np.clip(z[:n_source], 0.0, 1.0))])
        inner, _ = target.encode(batch, tol=1e-6)
        return np.concatenate([np.asarray(inner[0], dtype=float), z[n_source:]])

    return (
        frozen,
        lambda z: convert(z, problem.variables, frozen, n_full),
        lambda z: convert(z, frozen, problem.variables, n_held),
    )


def search_apertures(
    problem: GripperProblem,
    starts: list[NDArray],
    sorting: SortingSpec,
    evaluator: SceneEvaluator,
    *,
    max_iter: int,
    accept: Callable[[GripperProblem, NDArray], bool] | None = None,
) -> SortingSearch:
    """Apertures (and the point that has them) that maximise the loop's margin (docstring).

    ``starts[0]`` is the scene's own design (its margin is ``default``); the others (the
    scene's reference, fitted candidates) are evaluated as they stand, and the best start is
    the search's. ``accept(problem, z)``, when given, is asked of every point before it
    becomes the best (the scene's checks: the tip unit metastable, the pressure windows); a
    point it refuses counts as not realised.
    """
    g = problem.spec
    tol = g.aperture_tol
    goal = (TRIAL_GOAL * tol) ** 2
    start = gripper_at(problem, starts[0])
    lasts = tip_lasts(start, sorting, evaluator)
    default = loop_margins(start, sorting, lasts)
    search = SortingSearch(default, default, tuple(g.apertures), np.array(starts[0]), 1)
    search.apertures = tuple(float(a) for a in start.apertures)
    search.trace.append((list(search.apertures), default.margin))
    for z in starts[1:]:
        if search.evaluations >= sorting.max_evaluations:
            break
        try:
            other = gripper_at(problem, z)
            margins = loop_margins(other, sorting, lasts)
        except ValueError:
            continue
        search.evaluations += 1
        search.trace.append(([float(a) for a in other.apertures], margins.margin))
        if margins.margin > search.best.margin and (accept is None or accept(problem, z)):
            search.best, search.z = margins, np.array(z)
            search.apertures = tuple(float(a) for a in other.apertures)
    best_a = np.array(search.apertures)
    frozen, to_frozen, to_full = _domes_held(problem, search.z)
    z_frozen = {"z": to_frozen(search.z)}

    def trial(apertures: NDArray) -> float:
        """Realise ``apertures`` and compute its margin (NaN: not realised); keep the best."""
        if search.evaluations >= sorting.max_evaluations or np.any(np.diff(apertures) >= 0):
            return math.nan  # out of budget, or not the decreasing apertures of the sequence
        fit = replace(g, apertures=tuple(float(a) for a in apertures))
        trial_problem = GripperProblem(frozen, fit, evaluator)
        run: ResidualRefinement = refine_residual(
            trial_problem, z_frozen["z"], goal=goal, max_iter=2 * max_iter
        )
        residual = run.evaluation.residual[0]
        search.evaluations += 1
        margin = math.nan
        if np.all(np.isfinite(residual)) and np.max(np.abs(residual)) <= 0.5 * tol:
            try:
                margins = loop_margins(gripper_at(trial_problem, run.z), sorting, lasts)
            except ValueError:
                margins = None
            if margins is not None and margins.margin > search.best.margin:
                if accept is None or accept(trial_problem, run.z):
                    search.best, search.z = margins, to_full(run.z)
                    z_frozen["z"] = run.z
                    search.apertures = tuple(float(a) for a in apertures)
                    margin = margins.margin
                else:
                    search.refused += 1
            elif margins is not None:
                margin = margins.margin
        search.trace.append(([float(a) for a in apertures], margin))
        logger.info("sorting trial %s mm: margin %.4f", np.round(apertures, 3), margin)
        return margin

    goal_a = _secant(search.best, sorting, best_a)
    for fraction in SECANT_STEPS:  # in steps, each from the last point kept
        trial(np.array(search.apertures) + fraction * (goal_a - np.array(search.apertures)))
    remaining = sorting.max_evaluations - search.evaluations
    if remaining > 0:
        # Nelder-Mead on the apertures from the best so far: -margin, or a margin below every
        # realised one where the apertures cannot be realised
        start = np.array(search.apertures)
        simplex = [start] + [start - SIMPLEX_MM * np.eye(start.size)[j] for j in range(start.size)]

        def objective(a: NDArray) -> float:
            value = trial(a)
            return -value if math.isfinite(value) else 1e3

        minimize(
            objective,
            start,
            method="Nelder-Mead",
            options={
                "initial_simplex": np.array(simplex),
                "maxfev": remaining,
                "xatol": 0.05,
                "fatol": 1e-3,
            },
        )
    return search
