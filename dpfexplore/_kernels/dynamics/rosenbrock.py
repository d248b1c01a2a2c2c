"""Rodas4: a stiffly accurate, L-stable Rosenbrock method on the analytic Jacobian.

Why Rosenbrock, why Rodas4
    The lattice is small (``4N - 2 <= 46`` coordinates) and its Jacobian is cheap and exact:
    the Hessian from :func:`.lattice.assemble`, the damping matrix, the damping's position
    derivative and the pressure-follower Jacobian (:mod:`.dynamics.motion`). A Rosenbrock method
    uses it directly: one LU factorisation per step and six linear solves, no Newton iterations
    whose convergence could fail or need tuning. Rodas4 (Hairer & Wanner, *Solving ODEs II*, §VI.4,
    coefficients of their code RODAS) is L-stable and stiffly accurate, of order 4 with an
    embedded order-3 error estimate, and keeps its order on index-1 differential-algebraic
    systems. That last property lets one kernel integrate both models:

    * the full model, ``ẋ = v``, ``m v̇ = R(x, v, t)`` with ``R = F_ext - ∇E - F_damp - η_iso v``:
      the velocities relax on ``m/η ≈ 1e-5 s``, which L-stability damps without resolving;
    * the overdamped model, the same equations with ``m = 0``: ``0 = R(x, v, t)`` is an
      index-1 algebraic equation for ``v`` (``C(x) v = F_ext - ∇E``), solved by the method itself
      instead of factorising ``C`` at every stage.

Linear algebra
    With the mass matrix ``diag(I, m I)`` the stage system
    ``(diag(I, mI)/(hγ) - J) k = r`` reduces, eliminating ``k_v = k_x/(hγ) - r_x``, to
    ``S k_x = r_v + (m/(hγ) + C) r_x`` with ``S = m/(hγ)² + C/(hγ) + H + D - P_J``:
    ``H`` the Hessian, ``C`` the damping matrix, ``D = ∂F_damp/∂x`` at the step's velocities,
    ``P_J = ∂F_ext/∂x``. ``S`` is not symmetric under pressure (``P_J``): the banded LU of
    :mod:`.linalg.banded_lu` then, the block Cholesky of :mod:`.linalg.cholesky` when there is no
    pressure.

Cost per step
    One pass assembles the Hessian and, on the way, the gradient, so the first stage's
    right-hand side (at the step start) comes with the Jacobian; five more right-hand sides,
    one factorisation and six solves follow. A rejected step retries from the same point with
    the same Jacobian.

Shared with the other integrators
    The loop around the step (step cap, early stop, knots, rejections, the controller's memory)
    is the step driver of :mod:`.dynamics.stepping`; this module gives it the Rodas4 step
    (:func:`_rodas4_attempt`, compiled inline into :func:`rodas4`), the acceptance
    (:func:`accept_step`) and the step-size rules. The release integrator
    (:mod:`.reset.release`, Rodas3) also shares the consistent start
    (:func:`consistent_velocity`), the Jacobian pass at the step start (:func:`step_start`), the
    controller (:func:`accepted_step_factor`) and the acceptance; its stage loop is Rodas4's for
    zero mass with one more stage at the step start, written out there (``docs/decisions.md``,
    "One step driver").

Error control
    On the positions only (mixed ``atol`` mm / ``rtol``): events and outputs depend only on
    positions, and the velocities of both models are slaved to them on every time scale the
    steps resolve. A failed factorisation or a non-finite stage counts as a rejected step
    (step divided by 4); steps below ``CTRL_H_MIN`` or more than ``CTRL_MAX_STEPS`` end the run
    with a status instead of hanging.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...model import status as st
from .._jit import kernel
from ..layout import n_free, n_nodes
from ..linalg.banded_lu import LATTICE_HALF_BANDWIDTH as BAND
from ..linalg.banded_lu import lu_factor, lu_solve
from ..linalg.cholesky import band_matvec_add, cholesky, cholesky_solve
from ..records import AcceptedStep, MotionScratch, StepStart
from .events import (
    CTRL_ATOL,
    CTRL_H_INIT,
    CTRL_H_MAX,
    CTRL_RTOL,
    STAT_FACTOR,
    STAT_RHS,
    error_norm,
    init_record,
    pressure_slope,
    process_step,
    record_initial_samples,
)
from .motion import (
    PHYS_ETA,
    PHYS_ETA_ISO,
    PHYS_MASS,
    add_pressure_forces,
    damping_matrix,
    force_residual,
    pressure_at,
    residual_and_jacobian,
)
from .stepping import step_driver, stop_when_reset

# Rodas4 in the transformed form of Hairer & Wanner's RODAS code:
#   (M/(hγ) - J) K_i = f(t + α_i h, y + Σ_j A_ij K_j) + M Σ_j C_ij K_j / h + γ_i h ∂f/∂t,
#   y_new = y + Σ_j B_j K_j,  error estimate K_6.
RODAS4_GAMMA = 0.25
RODAS4_ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
RODAS4_GAMMA_SUM = np.array([0.25, -0.1043, 0.1035, -0.3620000000000023e-01, 0.0, 0.0])
RODAS4_A = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.1544e01, 0.0, 0.0, 0.0, 0.0],
        [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0],
        [0.3314825187068521e01, 0.2896124015972201e01, 0.9986419139977817, 0.0, 0.0],
        [
            0.1221224509226641e01,
            0.6019134481288629e01,
            0.1253708332932087e02,
            -0.6878860361058950,
            0.0,
        ],
        [
            0.1221224509226641e01,
            0.6019134481288629e01,
            0.1253708332932087e02,
            -0.6878860361058950,
            1.0,
        ],
    ]
)
RODAS4_C = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [-0.56688e01, 0.0, 0.0, 0.0, 0.0],
        [-0.2430093356833875e01, -0.2063599157091915, 0.0, 0.0, 0.0],
        [-0.1073529058151375, -0.9594562251023355e01, -0.2047028614809616e02, 0.0, 0.0],
        [
            0.7496443313967647e01,
            -0.1024680431464352e02,
            -0.3399990352819905e02,
            0.1170890893206160e02,
            0.0,
        ],
        [
            0.8083246795921522e01,
            -0.7981132988064893e01,
            -0.3152159432874371e02,
            0.1631930543123136e02,
            -0.6058818238834054e01,
        ],
    ]
)
RODAS4_B = np.array(
    [
        0.1221224509226641e01,
        0.6019134481288629e01,
        0.1253708332932087e02,
        -0.6878860361058950,
        1.0,
        1.0,
    ]
)
N_STAGES = 6

#: Step-size controller (Hairer & Wanner's RODAS): safety factor and smallest change, shared
#: with the Rodas3 of :mod:`.reset.release`; the largest change is each integrator's own.
SAFETY = 0.9
FAC_MIN = 0.2
_FAC_MAX = 6.0


@kernel
def consistent_velocity(x, t, model, scratch, cmat, piv, v):
    """Overdamped velocities ``v = C(x)⁻¹ (F_ext - ∇E)`` (the algebraic equation at ``t``).

    ``model``, ``scratch``: as for :func:`.dynamics.motion.force_residual`. Returns 0, or 1 if the
    damping matrix is singular.
    """
    unit_params, h, _, _, phys = model
    n = x.shape[0]
    for i in range(n):
        v[i] = 0.0
    force_residual(x, v, t, model, scratch, v)
    damping_matrix(
        scratch.pos, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO], scratch.work, cmat
    )
    if lu_factor(cmat, n, piv, BAND) != 0:
        return 1
    lu_solve(cmat, n, piv, v, BAND)
    return 0


@kernel
def step_start(x, v, t, step, model, scratch, out):
    """``R``, ``∂R/∂x``, ``C`` and ``∂R/∂t`` at the step start ``(t, x, v)``.

    Into ``out`` (:class:`~.records.StepStart`); ``model``, ``scratch`` as for
    :func:`.dynamics.motion.force_residual`. A rejected step retries from the same point, so
    these serve every retry; ``∂R/∂t`` is the pressure load at unit pressure times ``dP/dt``
    on this profile segment (steps never cross a knot, so a retry with a shorter step stays on
    it).
    """
    unit_params, h, knot_t, knot_p, phys = model
    pos, _, work = scratch
    res0, jac, cmat, ft = out
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    residual_and_jacobian(x, v, t, model, scratch, res0, jac)
    damping_matrix(pos, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO], work, cmat)
    slope = pressure_slope(t + 0.5 * step, knot_t, knot_p)
    for i in range(n):
        ft[i] = 0.0
    if slope != 0.0:
        add_pressure_forces(pos, n_units, slope, ft)


@kernel
def accepted_step_factor(err, step, h_acc, err_acc, expo, fac_max, last_rejected):
    """Next step over this accepted one: ``err^-expo``, and Gustafsson's predictive controller.

    ``expo`` is one over the order of the embedded solution plus one; ``h_acc``, ``err_acc``
    the previous accepted step and its error (``h_acc = 0``: none yet). As in Hairer &
    Wanner's RODAS, the more cautious of the two factors, and no growth right after a
    rejection.
    """
    fac = SAFETY * err**-expo if err > 0.0 else fac_max
    fac = min(fac_max, max(FAC_MIN, fac))
    if h_acc > 0.0 and err > 0.0:
        # the error trend over the last two steps
        fac_gus = SAFETY * (step / h_acc) * (err_acc / (err * err)) ** expo
        fac = min(fac, min(fac_max, max(FAC_MIN, fac_gus)))
    if last_rejected:
        fac = min(fac, 1.0)
    return fac


#: Rodas4's workspace (:func:`rodas4`): the model, controls and record it was given, the
#: right-hand side's scratch and the step start's :class:`~.records.StepStart`; the stage
#: matrix ``smat`` with its Cholesky factor ``low`` or LU pivots ``piv``, the stage residuals
#: ``res``, the stages ``kx``, ``kv`` (N_STAGES, 4N - 2), a stage's point ``yx``, ``yv`` and
#: right-hand sides ``rx``, ``rv``; the state ``x``, ``v`` (views into the caller's ``y``), the
#: step's end ``x_new``, ``v_new`` and the event margins ``g0``, ``g1`` (N,).
Rodas4Work = namedtuple(
    "Rodas4Work",
    "model ctrl record scratch start smat low piv res kx kv yx yv rx rv x v x_new v_new g0 g1",
)


@kernel(inline="always")
def _rodas4_attempt(work, t, step, retry):
    """One Rodas4 step of ``step`` s from ``(t, x, v)`` into ``x_new``, ``v_new``: ``(ok, err)``.

    The Jacobian pass at the step start is done once per point: a retry (``retry``, after a
    rejection) only changes the step size.
    """
    (model, ctrl, record, scratch, start, smat, low, piv, res, kx, kv, yx, yv, rx, rv) = work[:15]
    x, v, x_new, v_new = work.x, work.v, work.x_new, work.v_new
    _, _, knot_t, knot_p, phys = model
    res0, jac, cmat, ft = start
    stats = record.stats
    n = x.shape[0]
    mass = phys[PHYS_MASS]
    # Jacobian at (t, x, v): S = m/(hγ)² + C/(hγ) + H + D - P_J. A rejected step retries
    # from the same point, so only the step size changes.
    if not retry:
        step_start(x, v, t, step, model, scratch, start)
        stats[STAT_RHS] += 1
    hg = step * RODAS4_GAMMA
    inv_hg = 1.0 / hg
    diag_m = mass * inv_hg * inv_hg
    for i in range(n):
        for j in range(n):
            smat[i, j] = cmat[i, j] * inv_hg - jac[i, j]
        smat[i, i] += diag_m
    stats[STAT_FACTOR] += 1
    # Without pressure at t the matrix is symmetric (P_J is the only non-symmetric part),
    # and mostly positive definite: the block Cholesky then takes a quarter of the LU's
    # time and its solves a third. Where it fails, the banded LU decides.
    symmetric = pressure_at(t, knot_t, knot_p) == 0.0
    use_cholesky = symmetric and cholesky(smat, 0.0, low, n)
    ok = use_cholesky or lu_factor(smat, n, piv, BAND) == 0
    err = math.inf
    if ok:
        inv_step = 1.0 / step
        for s in range(N_STAGES):
            # stage point y + Σ A_sj K_j and Σ C_sj K_j / h, one earlier stage at a time
            for i in range(n):
                yx[i] = x[i]
                yv[i] = v[i]
                rx[i] = 0.0
                rv[i] = 0.0
            for j in range(s):
                a_sj = RODAS4_A[s, j]
                c_sj = RODAS4_C[s, j] * inv_step
                kx_j = kx[j]
                kv_j = kv[j]
                for i in range(n):
                    yx[i] += a_sj * kx_j[i]
                    yv[i] += a_sj * kv_j[i]
                    rx[i] += c_sj * kx_j[i]
                    rv[i] += c_sj * kv_j[i]
            for i in range(n):
                rx[i] += yv[i]
                rv[i] *= mass
            if s == 0:  # the step start itself (α_1 = 0)
                for i in range(n):
                    res[i] = res0[i]
            else:
                t_stage = t + RODAS4_ALPHA[s] * step
                force_residual(yx, yv, t_stage, model, scratch, res)
                stats[STAT_RHS] += 1
            gam_h = RODAS4_GAMMA_SUM[s] * step
            for i in range(n):
                rv[i] += res[i] + gam_h * ft[i]
            # right-hand side r_v + (m/(hγ) + C) r_x, then k_v = k_x/(hγ) - r_x
            kx_s = kx[s]
            for i in range(n):
                kx_s[i] = rv[i] + mass * inv_hg * rx[i]
            band_matvec_add(cmat, rx, n, BAND, kx_s)
            if use_cholesky:
                cholesky_solve(low, kx[s], kx[s], n)
            else:
                lu_solve(smat, n, piv, kx[s], BAND)
            for i in range(n):
                kv[s, i] = kx[s, i] * inv_hg - rx[i]
        for i in range(n):
            bx = x[i]
            bv = v[i]
            for s in range(N_STAGES):
                bx += RODAS4_B[s] * kx[s, i]
                bv += RODAS4_B[s] * kv[s, i]
            x_new[i] = bx
            v_new[i] = bv
        err = error_norm(kx[N_STAGES - 1], x, x_new, n, ctrl[CTRL_RTOL], ctrl[CTRL_ATOL])
        ok = math.isfinite(err)
        for i in range(n):
            if not (math.isfinite(x_new[i]) and math.isfinite(v_new[i])):
                ok = False
    return ok, err


@kernel(inline="always")
def accept_step(work, t, step, err):
    """Record the accepted step ``(t, x, v) → (t + step, x_new, v_new)`` and move to its end.

    ``work`` needs the fields ``model``, ``record``, ``x``, ``v``, ``x_new``, ``v_new``, ``g0``
    and ``g1`` (as :data:`Rodas4Work`).
    """
    x, v, x_new, v_new = work.x, work.v, work.x_new, work.v_new
    accepted = AcceptedStep(t, step, x, v, x_new, v_new)
    process_step(accepted, work.g0, work.g1, work.model.unit_params, work.record)
    for i in range(x.shape[0]):
        x[i] = x_new[i]
        v[i] = v_new[i]


@kernel(inline="always")
def _rodas4_accepted_factor(err, step, h_acc, err_acc, last_rejected):
    """:func:`accepted_step_factor` with Rodas4's exponent (order 3 + 1) and largest change."""
    return accepted_step_factor(err, step, h_acc, max(1e-2, err_acc), 0.25, _FAC_MAX, last_rejected)


@kernel(inline="always")
def _rodas4_rejected_factor(err):
    """The retry's step over a rejected one: ``err^-1/4``, no less than :data:`FAC_MIN`."""
    return max(FAC_MIN, SAFETY * err**-0.25)


_rodas4_steps = step_driver(
    stop_when_reset, _rodas4_attempt, accept_step, _rodas4_accepted_factor, _rodas4_rejected_factor
)


@kernel
def rodas4(y, t0, t_end, model, ctrl, record):
    """Integrate from ``t0`` to ``t_end`` (s) in place in ``y = [x, v]``; returns a status.

    Parameters
    ----------
    y : ndarray of shape (2 (4N - 2),)
        Positions (mm) then velocities (mm/s); overwritten with the final state. For the
        overdamped model (``phys[PHYS_MASS] == 0``) the velocities are recomputed consistently.
    t0, t_end : float, s
    model : MotionModel
        Lattice parameters ``unit_params``, ``h`` (:mod:`.layout`), the piecewise-linear
        pressure profile ``knot_t``, ``knot_p`` (s, MPa) and ``phys`` of shape (N_PHYS,),
        ``(η, η_iso, node mass)``; mass 0 selects the overdamped model (:mod:`.records`).
    ctrl : ndarray of shape (N_CTRL,)
        Solver controls (:mod:`.dynamics.events`).
    record : RunRecord
        Increasing output times ``t_out`` (s, shape ``(m,)``) and ``x_out`` (shape
        ``(m, 4N - 2)``) receiving the positions; the event records and counters
        ``unit_rec``, ``event_log``, ``stats`` (:mod:`.dynamics.events`).
    """
    unit_params, _, knot_t, _, phys = model
    t_out, x_out, unit_rec, _, stats = record
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    cmat = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    x = y[:n]
    v = y[n:]
    scratch = MotionScratch(
        np.empty((n_nodes(n_units), 2)), np.empty((n_nodes(n_units), 2)), np.empty(n)
    )
    start = StepStart(np.empty(n), np.empty((n, n)), cmat, np.empty(n))
    if phys[PHYS_MASS] == 0.0:
        if consistent_velocity(x, t0, model, scratch, cmat, piv, v) != 0:
            return st.DEGENERATE_GEOMETRY
    g0 = np.empty(n_units)
    init_record(x, t0, unit_params, unit_rec, stats, g0)
    record_initial_samples(t0, x, t_out, x_out, stats)
    work = Rodas4Work(
        model,
        ctrl,
        record,
        scratch,
        start,
        np.empty((n, n)),
        np.empty((n, n)),
        piv,
        np.empty(n),
        np.empty((N_STAGES, n)),
        np.empty((N_STAGES, n)),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        x,
        v,
        np.empty(n),
        np.empty(n),
        g0,
        np.empty(n_units),
    )
    step = ctrl[CTRL_H_INIT]
    if step <= 0.0:
        step = 1e-6
    step = min(step, ctrl[CTRL_H_MAX])
    return _rodas4_steps(work, t0, t_end, step, ctrl, knot_t, stats)
