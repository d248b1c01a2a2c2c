"""The multi-aperture gripper scene (paper eq. opti_multi; MODEL.md §7, §9).

Method
------
1. **Candidates.** A Latin hypercube over the finger's variables only. Each candidate's four
   sequential states are solved once; the base angle ``θ_B`` and length ``Base_L`` that fit its
   apertures best follow without any further solve: the aperture is
   ``a_j = 2 Base_L - 2 u_j(θ)`` with ``u_j = sin θ x_j + cos θ (y_j - h)``, so for each ``θ``
   of a fine grid the best ``Base_L`` is a mean, and ``θ`` is the grid's best.
2. **Apertures met.** Trust-region least squares on all variables (finger, ``θ_B``,
   ``Base_L``) from the best distinct candidates, until every aperture is within a small
   fraction of its tolerance.
3. **Stiffness maximised.** SLSQP maximises the tip stiffness of the activated state subject to
   the apertures staying within half their tolerance and the tip unit staying in a band of its
   isolated-dome ``α`` (above the bistable limit ``1/9``, below a cap): the cheap, analytic proxy
   of metastability that keeps the search where the dynamics can hold. Every state's
   pressure window (snap-pressure continuation) is at least ``min_window_kPa``
   (finite-difference gradients of the windows). Consecutive ordered heights differ by the
   scene's ``variables.min_step`` exactly (the box map), since equal domes would snap
   together and leave no window between their states.
4. **Finalists simulated.** Only the final candidates are simulated in the full model under the
   scene's pressure pulse: the tip unit must reset, after at least ``min_reset_s``, while the
   others stay inverted. A finalist that resets too soon has the top of its ``α`` band
   lowered toward ``1/9`` (one that never resets, its floor raised), and step 3 is repeated
   from it. Then the finalists' pressure windows are checked (the release windows of the
   snap-pressure continuation: :mod:`.windows`), and the stiffest finalist that is
   metastable and has its windows wins.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design
from ....model.pressure import PressureProfile
from ....solvers.dynamics.simulate import simulate
from ...engine.optimiser import (
    ResidualRefinement,
    TargetResult,
    distinct_starts,
    latin_candidates,
    maximise_stiffness,
    refine_residual,
)
from ...engine.problem import Evaluation
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .problem import GripperProblem
from .spec import GripperSpec
from .windows import PressureWindows, pressure_windows, window_widths

logger = logging.getLogger(__name__)

__all__ = [
    "ALPHA_BISTABLE",
    "GripperTargetResult",
    "Metastability",
    "gripper_problem",
    "metastability",
    "solve_gripper",
]


class Metastability(TypedDict):
    """A full-model run of the scene's pulse (:func:`metastability`).

    ``ok``: the tip unit reset, after at least ``min_reset_s``, and alone; ``reset_time_s`` its
    reset time (s, ``inf`` never, NaN never inverted); ``status`` the run's; ``final_state``;
    ``classes`` of every unit; ``others_stay_inverted``.
    """

    ok: bool
    reset_time_s: float
    status: str
    final_state: str
    classes: list[str | None]
    others_stay_inverted: bool


class Finalist(TypedDict):
    """A stiffened finalist's stiffness (N/mm), metastability and whether its windows hold."""

    stiffness: float
    checks: Metastability
    windows_ok: bool


@dataclass
class GripperTargetResult(TargetResult):
    """The optimiser's result for the gripper, with the checks of the chosen finalist.

    Attributes
    ----------
    metastability : Metastability or empty
        The chosen finalist's pulse run (empty when no finalist met the apertures).
    alpha_band : [low, high] or None
        The tip unit's isolated-dome ``α`` band of the last stiffening round.
    windows : PressureWindows or empty
        The best design's pressure windows (:func:`.windows.pressure_windows`).
    finalists : list of Finalist
    """

    metastability: Metastability | dict = field(default_factory=dict)
    alpha_band: list[float] | None = None
    windows: PressureWindows | dict = field(default_factory=dict)
    finalists: list[Finalist] = field(default_factory=list)


#: Isolated-dome bistability limit (MODEL.md §4).
ALPHA_BISTABLE = 1.0 / 9.0
#: Bisection rounds on the tip unit's alpha band (each one SLSQP run and one simulation).
_ROUNDS = 6
#: Grid of base angles of the candidate step.
_THETA_GRID = 721


def gripper_problem(spec: SceneSpec[GripperSpec], evaluator: SceneEvaluator) -> GripperProblem:
    """The gripper problem of a scene."""
    return GripperProblem(spec.design_variables(spec.n_units[0]), spec.kind_spec, evaluator)


def _best_base(problem: GripperProblem, ev: Evaluation) -> NDArray:
    """Box coordinates of the ``θ_B``, ``Base_L`` that fit each candidate's apertures best."""
    g = problem.spec
    (t0, t1), (b0, b1) = g.theta_B_deg, g.base_L
    theta = np.radians(np.linspace(t0, t1, _THETA_GRID))
    tips = ev.columns["_tips"]  # (m, S, 2)
    x = tips[..., 0][:, None, :]
    y = (tips[..., 1] - ev.columns["_h"][:, None])[:, None, :]
    u = np.sin(theta)[None, :, None] * x + np.cos(theta)[None, :, None] * y  # (m, G, S)
    targets = np.asarray(g.apertures)
    base = np.clip(np.mean(u + targets / 2.0, axis=2), b0, b1)  # (m, G)
    cost = np.sum((2.0 * base[..., None] - 2.0 * u - targets) ** 2, axis=2)
    cost = np.where(np.isfinite(cost), cost, np.inf)
    k = np.argmin(cost, axis=1)
    rows = np.arange(len(k))
    z_theta = (np.degrees(theta[k]) - t0) / (t1 - t0) if t1 > t0 else np.zeros(len(k))
    z_base = (base[rows, k] - b0) / (b1 - b0) if b1 > b0 else np.zeros(len(k))
    return np.column_stack([np.clip(z_theta, 0, 1), np.clip(z_base, 0, 1)])


def _screen(problem: GripperProblem, z_finger: NDArray) -> Evaluation:
    """Candidates with their best base: one solve of the states per candidate."""
    z = np.column_stack([z_finger, np.full((len(z_finger), 2), 0.5)])
    batch, states, want = problem.requests(z, stiffness=False)
    out = problem.evaluator.solve(batch, states, stiffness=want)
    first = problem.finish(z, batch, out)
    z[:, problem.n_finger :] = _best_base(problem, first)
    ev = problem.finish(z, batch, out)
    problem.record(batch, ev, "candidate")
    return ev


def alpha_of(problem: GripperProblem, z: NDArray) -> float:
    """Isolated-dome ``α`` of the metastable unit at a box point (closed form, no solve)."""
    design = problem.designs(np.atleast_2d(z))
    k = problem.spec.metastable_unit - 1
    H, t = design.H[0, k], design.t[0]
    return float(design.constants.evaluate(H, t, design.r_b[0], design.E[0])["alpha"])


def _alpha_band(problem: GripperProblem, low: float, high: float) -> list[dict]:
    """SLSQP constraints ``low <= α <= high`` with central-difference gradients (closed form)."""

    def grad(z: NDArray, sign: float) -> NDArray:
        g = np.zeros_like(z)
        for j in range(problem.n_finger):
            up, down = z.copy(), z.copy()
            up[j], down[j] = min(z[j] + 1e-6, 1.0), max(z[j] - 1e-6, 0.0)
            if up[j] > down[j]:
                g[j] = sign * (alpha_of(problem, up) - alpha_of(problem, down)) / (up[j] - down[j])
        return g

    return [
        {
            "type": "ineq",
            "fun": lambda z: alpha_of(problem, z) - low,
            "jac": lambda z: grad(z, 1.0),
        },
        {
            "type": "ineq",
            "fun": lambda z: high - alpha_of(problem, z),
            "jac": lambda z: grad(z, -1.0),
        },
    ]


def _window_constraints(problem: GripperProblem, evaluator: SceneEvaluator) -> list[dict]:
    """SLSQP constraints ``window_j >= min_window`` (kPa) from the snap-pressure continuation."""
    g = problem.spec
    cache: dict = {}

    def widths(z: NDArray) -> NDArray:
        key = np.clip(z, 0, 1).tobytes()
        if key not in cache:
            design = problem.designs(np.atleast_2d(np.clip(z, 0, 1))).design(0)
            cache[key] = np.maximum(np.array(window_widths(design, g.states, evaluator)), -1e3)
        return cache[key]

    def grad(z: NDArray, j: int) -> NDArray:
        out = np.zeros_like(z)
        for i in range(problem.n_finger):
            up, down = z.copy(), z.copy()
            up[i], down[i] = min(z[i] + 1e-5, 1.0), max(z[i] - 1e-5, 0.0)
            out[i] = (widths(up)[j] - widths(down)[j]) / (up[i] - down[i])
        return out

    return [
        {
            "type": "ineq",
            "fun": lambda z, j=j: widths(z)[j] - g.min_window_kPa,
            "jac": lambda z, j=j: grad(z, j),
        }
        for j in range(len(g.states))
    ]


def metastability(design: Design, g: GripperSpec, evaluator: SceneEvaluator) -> Metastability:
    """Full-model run of the scene's pulse: the tip unit must reset late enough, and alone."""
    profile = PressureProfile.pulse(g.pulse_P0, g.pulse_tau)
    run = simulate(design, profile, t_end=g.pulse_t_end, stop_when_reset=True, n_samples=0)
    evaluator.count("simulations")
    k = g.metastable_unit - 1
    reset = float(run.reset_time[k])
    others = [i for i in range(design.n_units) if i != k and g.activated[i] == "1"]
    others_stay = all(math.isinf(float(run.reset_time[i])) for i in others)
    ok = run.status.label == "ok" and np.isfinite(reset) and reset >= g.min_reset_s and others_stay
    return {
        "ok": bool(ok),
        "reset_time_s": reset,
        "status": run.status.label,
        "final_state": run.final_state,
        "classes": list(run.unit_class),
        "others_stay_inverted": bool(others_stay),
    }


def windows_ok(windows: PressureWindows, min_window_kPa: float) -> bool:
    """Every targeted state met in order, each window at least ``min_window_kPa`` wide."""
    return bool(windows.get("in_order")) and all(
        w is not None and w[1] - w[0] >= min_window_kPa for w in windows["windows"]
    )


def solve_gripper(
    spec: SceneSpec[GripperSpec], target_index: int, evaluator: SceneEvaluator
) -> GripperTargetResult:
    """Design the multi-aperture gripper of a scene (see the module docstring)."""
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    g = spec.kind_spec
    settings = spec.optimiser
    problem = gripper_problem(spec, evaluator)
    zf = latin_candidates(problem.n_finger, settings.candidates_per_n, spec.seed)
    candidates = _screen(problem, zf)
    tol = g.aperture_tol
    goal = (1e-3 * tol) ** 2
    result = GripperTargetResult(
        target_index=0,
        target=tuple(g.apertures),
        best=None,
        reachable=False,
        per_n={problem.n_units: float(np.min(candidates.objective))},
    )
    for i in distinct_starts(candidates, settings.starts_per_n):
        run = refine_residual(problem, candidates.z[i], goal=goal, max_iter=settings.max_iter)
        result.starts.append(run)
        if result.best is None or run.objective < result.best.objective:
            result.best = run
    finalists = []
    for run in sorted(result.starts, key=lambda r: r.objective):
        if np.max(np.abs(run.evaluation.residual[0])) > 0.5 * tol:
            continue
        finalist = _stiffen(problem, run, evaluator, spec)
        design = problem.designs(np.atleast_2d(finalist["refinement"].z)).design(0)
        windows = pressure_windows(design, g.states, evaluator)
        finalist["windows"] = windows
        finalist["windows_ok"] = windows_ok(windows, g.min_window_kPa)
        finalists.append(finalist)
    # Metastable and with its windows first, then metastable, then the rest; stiffest wins.
    pool = (
        [f for f in finalists if f["checks"]["ok"] and f["windows_ok"]]
        or [f for f in finalists if f["checks"]["ok"]]
        or finalists
    )
    if pool:
        best = max(pool, key=lambda f: f["stiffness"])
        result.best = best["refinement"]
        result.metastability = best["checks"]
        result.alpha_band = best["band"]
        result.windows = best["windows"]
        result.finalists = [
            Finalist(stiffness=f["stiffness"], checks=f["checks"], windows_ok=f["windows_ok"])
            for f in finalists
        ]
    result.reachable = result.best is not None and bool(
        np.max(np.abs(np.nan_to_num(result.best.evaluation.residual[0], nan=np.inf))) <= tol
    )
    if result.best is not None and not pool:
        design = problem.designs(np.atleast_2d(result.best.z)).design(0)
        result.windows = pressure_windows(design, g.states, evaluator)
    result.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    result.wall_s = evaluator.wall_s - wall0
    return result


#: Step of the alpha band beyond a failed finalist while only one side of the bracket is known.
_ALPHA_STEP = 0.02


def _next_band(a_lo: float, a_hi: float) -> tuple[float, float]:
    """The alpha band of the next round from the bracket ``(a_lo, a_hi)`` of failed alphas.

    With both sides known, the middle half of the bracket (bisection); with one side only, a
    narrow band one step beyond it (a far band may leave the apertures unreachable nearby).
    """
    top_known, bottom_known = a_hi < 1.0 / 3.0, a_lo > ALPHA_BISTABLE
    if not (top_known or bottom_known):  # only alphas below the bistable limit failed
        return ALPHA_BISTABLE, ALPHA_BISTABLE + _ALPHA_STEP
    if top_known and bottom_known:
        mid, width = 0.5 * (a_lo + a_hi), 0.25 * (a_hi - a_lo)
        return mid - width, mid + width
    if bottom_known:
        return a_lo + 0.5 * _ALPHA_STEP, a_lo + 1.5 * _ALPHA_STEP
    return max(ALPHA_BISTABLE, a_hi - 1.5 * _ALPHA_STEP), a_hi - 0.5 * _ALPHA_STEP


def _stiffen(
    problem: GripperProblem, run: ResidualRefinement, evaluator: SceneEvaluator, spec: SceneSpec
) -> dict:
    """Maximise the activated state's stiffness from an aperture solution; simulate the result."""
    g = problem.spec
    tol = 0.5 * g.aperture_tol
    # Bracket of the tip unit's alpha: at or below a_lo it stayed inverted (bistable in the
    # finger), at or above a_hi it reset too soon. Each failed round moves the band to the right
    # side of its alpha (see _next_band).
    a_lo, a_hi = ALPHA_BISTABLE, 1.0 / 3.0
    low, high = a_lo, float(np.clip(alpha_of(problem, run.z), a_lo + 0.01, a_hi))
    z = run.z
    ev = run.evaluation
    checks: dict = {}
    order = []
    if g.min_window_kPa > 0:
        order = _window_constraints(problem, evaluator)
    for _ in range(_ROUNDS):
        band = _alpha_band(problem, low, high) + order
        z_new, ev_new = maximise_stiffness(
            problem, z, tol, max_iter=spec.optimiser.max_iter, extra_constraints=band
        )
        if z_new is not None:
            z, ev = z_new, ev_new
        checks = metastability(problem.designs(np.atleast_2d(z)).design(0), g, evaluator)
        alpha = alpha_of(problem, z)
        logger.info(
            "gripper finalist: alpha %.4f in [%.4f, %.4f], reset %s s, stiffness %.5f",
            alpha,
            low,
            high,
            checks["reset_time_s"],
            ev.stiffness[0],
        )
        if checks["ok"]:
            break
        if np.isfinite(checks["reset_time_s"]):  # resets too soon: below this alpha
            a_hi = min(a_hi, alpha)
        else:  # never resets: above this alpha
            a_lo = max(a_lo, alpha)
        low, high = _next_band(a_lo, a_hi)
    if not np.isfinite(ev.stiffness[0]):
        ev = problem.evaluate(np.atleast_2d(z), purpose="front", stiffness=True)
    refinement = ResidualRefinement(
        problem=problem,
        z=z,
        evaluation=ev,
        objective=float(ev.objective[0]),
        iterations=0,
        reached=True,
    )
    return {
        "refinement": refinement,
        "stiffness": float(ev.stiffness[0]),
        "checks": checks,
        "band": [low, high],
    }
