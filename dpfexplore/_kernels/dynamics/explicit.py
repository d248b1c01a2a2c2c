"""Dormand–Prince 5(4): the adaptive explicit Runge–Kutta pair (the paper's "Runge–Kutta").

Two right-hand sides share the pair:

* the full model, ``y = [x, v]``, ``ẏ = [v, R(x, v, t)/m]``. Its velocities relax at
  ``η/m ≈ 1e5 /s``, so the stable step is ~1e-5 s whatever the tolerance: about 10⁶ steps
  for a 15 s scene. That cost is the reason for the stiff integrators; it is measured, not
  assumed (``dpfexplore bench dynamics``).
* the overdamped model, ``ẋ = C(x)⁻¹ (F_ext - ∇E)``, one banded LU of the damping matrix per
  stage. Its stiffest mode (posts, ``k_post / η``) still limits the step to ~1e-4 s.

Coefficients: Dormand & Prince (1980), the pair of Hairer, Nørsett & Wanner's DOPRI5 with its
step-size control (PI controller with ``β = 0.04``). The last stage is the first of the next
step (FSAL), so the slopes at both step ends are free for the Hermite dense output. The error
norm is on the positions only, as in :mod:`.dynamics.rosenbrock`; instability of the
velocities shows in the positions within a step or two and is rejected there. The loop around
the step is the step driver of :mod:`.dynamics.stepping`.
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
from ..records import AcceptedStep, MotionScratch
from .events import (
    CTRL_ATOL,
    CTRL_H_INIT,
    CTRL_H_MAX,
    CTRL_RTOL,
    STAT_FACTOR,
    STAT_RHS,
    error_norm,
    init_record,
    process_step,
    record_initial_samples,
)
from .motion import PHYS_ETA, PHYS_ETA_ISO, PHYS_MASS, damping_matrix, force_residual
from .stepping import step_driver, stop_when_reset

DP_C = np.array([0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0])
DP_A = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
        [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
        [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
    ]
)
DP_B = np.array(
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0, 0.0]
)
#: ``b - b̂`` (fifth- minus fourth-order weights): the local error estimate.
DP_E = np.array(
    [
        71.0 / 57600.0,
        0.0,
        -71.0 / 16695.0,
        71.0 / 1920.0,
        -17253.0 / 339200.0,
        22.0 / 525.0,
        -1.0 / 40.0,
    ]
)
N_DP_STAGES = 7

_SAFETY = 0.9
_BETA = 0.04
_FAC_MIN = 0.2
_FAC_MAX = 10.0


@kernel
def _slope(y, t, n, model, scratch, cmat, piv, out):
    """``ẏ`` of the full model (``m > 0``) or ``ẋ`` of the overdamped one (``m = 0``).

    ``model``, ``scratch``: as for :func:`.dynamics.motion.force_residual`. Returns 0, or 1 if the
    overdamped damping matrix is singular.
    """
    unit_params, h, _, _, phys = model
    pos, _, work = scratch
    mass = phys[PHYS_MASS]
    if mass > 0.0:
        force_residual(y[:n], y[n:], t, model, scratch, out[n:])
        inv_m = 1.0 / mass
        for i in range(n):
            out[i] = y[n + i]
            out[n + i] *= inv_m
        return 0
    # Overdamped: at v = 0 the residual is F_ext - ∇E; then solve C ẋ = that.
    for i in range(n):
        out[n + i] = 0.0
    force_residual(y[:n], out[n:], t, model, scratch, out)
    damping_matrix(pos, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO], work, cmat)
    if lu_factor(cmat, n, piv, BAND) != 0:
        return 1
    lu_solve(cmat, n, piv, out[:n], BAND)
    return 0


#: Dormand-Prince's workspace (:func:`dopri5`): the model, controls and record it was given, the
#: right-hand side's scratch, the overdamped model's damping matrix ``cmat`` and pivots
#: ``piv``, the stages ``k`` (N_DP_STAGES, 2 (4N - 2)), the state ``y`` (the caller's), a
#: stage's point ``y_stage`` and the step's end ``y_new`` (2 (4N - 2),), the error estimate
#: ``err_vec`` (4N - 2,) and the event margins ``g0``, ``g1`` (N,).
Dopri5Work = namedtuple(
    "Dopri5Work",
    "model ctrl record scratch cmat piv k y y_stage y_new err_vec g0 g1",
)


@kernel(inline="always")
def _dopri5_attempt(work, t, step, retry):
    """One Dormand-Prince step of ``step`` s from ``(t, y)`` into ``y_new``: ``(ok, err)``.

    ``k[0]`` holds the slope at the step start (FSAL); the last stage is the fifth-order
    solution. A failed overdamped slope (singular damping matrix) or a non-finite error fails
    the attempt.
    """
    model, ctrl, record, scratch, cmat, piv, k, y, y_stage, y_new, err_vec, _, _ = work
    stats = record.stats
    n = err_vec.shape[0]
    dim = 2 * n if model.phys[PHYS_MASS] > 0.0 else n
    ok = True
    for s in range(1, N_DP_STAGES):
        for i in range(dim):
            acc = y[i]
            for j in range(s):
                acc += step * DP_A[s, j] * k[j, i]
            y_stage[i] = acc
        if _slope(
            y_stage,
            t + DP_C[s] * step,
            n,
            model,
            scratch,
            cmat,
            piv,
            k[s],
        ):
            ok = False
            break
        stats[STAT_RHS] += 1
    if dim == n:
        stats[STAT_FACTOR] += N_DP_STAGES - 1
    err = math.inf
    if ok:
        # y_stage holds the last stage = the fifth-order solution (FSAL).
        for i in range(dim):
            y_new[i] = y_stage[i]
        for i in range(n):
            e = 0.0
            for s in range(N_DP_STAGES):
                e += DP_E[s] * k[s, i]
            err_vec[i] = step * e
        err = error_norm(err_vec, y, y_new, n, ctrl[CTRL_RTOL], ctrl[CTRL_ATOL])
    return math.isfinite(err), err


@kernel(inline="always")
def _dopri5_accept(work, t, step, err):
    """Record the accepted step and move to its end; its last stage is the next one's first."""
    model, _, record, _, _, _, k, y, _, y_new, err_vec, g0, g1 = work
    n = err_vec.shape[0]
    if not model.phys[PHYS_MASS] > 0.0:  # overdamped: y holds x, and ẋ for the dense output
        # ẋ at both ends for the dense output: k[0] and the FSAL stage k[6].
        for i in range(n):
            y_new[n + i] = k[N_DP_STAGES - 1, i]
    process_step(
        AcceptedStep(t, step, y[:n], y[n:], y_new[:n], y_new[n:]),
        g0,
        g1,
        model.unit_params,
        record,
    )
    for i in range(2 * n):
        y[i] = y_new[i]
    for i in range(2 * n):
        k[0, i] = k[N_DP_STAGES - 1, i]


@kernel(inline="always")
def _dopri5_accepted_factor(err, step, h_acc, err_acc, last_rejected):
    """DOPRI5's PI controller (``β = 0.04``); the previous error counts as at least 1e-4."""
    err_old = max(err_acc, 1e-4)
    fac = _SAFETY * max(err, 1e-10) ** (-0.2 + 0.75 * _BETA) * err_old**_BETA
    fac = min(_FAC_MAX, max(_FAC_MIN, fac))
    if last_rejected:
        fac = min(fac, 1.0)
    return fac


@kernel(inline="always")
def _dopri5_rejected_factor(err):
    """The retry's step over a rejected one (no less than a fifth)."""
    return max(_FAC_MIN, _SAFETY * err ** (-0.2 + 0.75 * _BETA))


_dopri5_steps = step_driver(
    stop_when_reset,
    _dopri5_attempt,
    _dopri5_accept,
    _dopri5_accepted_factor,
    _dopri5_rejected_factor,
)


@kernel
def dopri5(y, t0, t_end, model, ctrl, record):
    """Integrate from ``t0`` to ``t_end`` (s) in place in ``y = [x, v]``; returns a status.

    Same arguments as :func:`.dynamics.rosenbrock.rodas4`. For the overdamped model
    (``phys[PHYS_MASS] == 0``) only ``x`` is integrated and ``v`` receives ``ẋ``.
    """
    unit_params, _, knot_t, _, phys = model
    t_out, x_out, unit_rec, _, stats = record
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    scratch = MotionScratch(
        np.empty((n_nodes(n_units), 2)), np.empty((n_nodes(n_units), 2)), np.empty(n)
    )
    work = Dopri5Work(
        model,
        ctrl,
        record,
        scratch,
        np.empty((n, n)),
        np.empty(n, dtype=np.int64),
        np.zeros((N_DP_STAGES, 2 * n)),
        y,
        np.zeros(2 * n),
        np.zeros(2 * n),
        np.empty(n),
        np.empty(n_units),
        np.empty(n_units),
    )
    k = work.k
    if _slope(y, t0, n, model, scratch, work.cmat, work.piv, k[0]):
        return st.DEGENERATE_GEOMETRY
    init_record(y[:n], t0, unit_params, unit_rec, stats, work.g0)
    record_initial_samples(t0, y[:n], t_out, x_out, stats)
    stats[STAT_RHS] = 1
    if not phys[PHYS_MASS] > 0.0:
        for i in range(n):
            y[n + i] = k[0, i]
    step = ctrl[CTRL_H_INIT]
    if step <= 0.0:
        step = 1e-7
    step = min(step, ctrl[CTRL_H_MAX])
    return _dopri5_steps(work, t0, t_end, step, ctrl, knot_t, stats)
