"""The release of a held finger: overdamped Rodas3 from the loaded equilibrium to the last reset.

The fast reset model (:mod:`.reset.fast_reset`) starts the dynamics at the end of the hold, in the
loaded equilibrium of :mod:`.reset.loaded_state`, and integrates only what decides the reset times:
the release ramp and the creep after it. The equations are the overdamped model of
:mod:`.dynamics.motion` (``C(x) v = F_ext - ∇E``, an index-1 system for the velocities, exactly as
the ``rodas4-overdamped`` method treats it: inertia changes reset times by ~1e-5 relative).

Why Rodas3 here
    Rodas3 (Sandu et al., *Atmos. Environ.* 31, 1997: four stages, order 3, embedded order 2,
    L-stable and stiffly accurate, so it keeps its order on the index-1 system) needs two new
    right-hand sides and four solves per step against Rodas4's five and six, and with the
    stage-2 point equal to the step start it reuses the right-hand side of the Jacobian pass.
    On random metastable designs at an equal reset-time error it took fewer right-hand sides
    than Rodas4 at the loose tolerances this model runs at (position tolerance ~3e-3 mm).
    The stage algebra is that of :mod:`.dynamics.rosenbrock` (stage matrix
    ``C/(hγ) + H + D - P_J``, block Cholesky without pressure, banded LU with it), whose
    consistent start, step-start Jacobian, step-size controller and acceptance it calls; its
    stage loop is Rodas4's without the mass terms, written out here for the reason given there.
    The loop around the step is the step driver of :mod:`.dynamics.stepping`, with the stop
    rules below.
When to stop
    Reset times are the units' last downward threshold crossings, so the run must not stop
    while a crossing can still happen. It stops (a) when every inverted unit has reset and
    nothing has crossed for :data:`.dynamics.events.SETTLE_TIME`, as ``reset_times_batch`` does, or
    (b) once nothing has crossed for that time and a static check agrees that the current
    pattern is final: Newton from the current state
    (:func:`.statics.newton.minimize`, no pressure) reaches a minimum with the same inverted units.
    A neighbour's snap can push a dome that crossed its threshold back over it (a crossing at
    ``u = 3/4`` inside the ghost of a metastable dome is not yet a snap), which is why the check
    waits for the motion to settle instead of trusting the first crossing. Otherwise the run
    ends at the horizon.
Per-unit diagnostics
    The step size and error estimate of the step that held each unit's last downward crossing:
    the event time comes from a cubic Hermite interpolant on that step, so a long step is a
    less certain time (the fitted interval of :mod:`dpfexplore.solvers.dynamics.fast_reset` uses
    them).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...model import status as st
from .._jit import kernel
from ..dynamics.events import (
    CTRL_ATOL,
    CTRL_H_INIT,
    CTRL_H_MAX,
    CTRL_RTOL,
    REC_INVERTED,
    REC_LAST_DOWN,
    SETTLE_TIME,
    STAT_EVENTS,
    STAT_FACTOR,
    STAT_RHS,
    STAT_STOPPED_EARLY,
    error_norm,
    init_record,
    settled_reset,
)
from ..dynamics.motion import force_residual, pressure_at
from ..dynamics.rosenbrock import (
    FAC_MIN,
    SAFETY,
    accept_step,
    accepted_step_factor,
    consistent_velocity,
    step_start,
)
from ..dynamics.stepping import GO_ON, step_driver
from ..layout import n_free, n_nodes
from ..linalg.banded_lu import LATTICE_HALF_BANDWIDTH as BAND
from ..linalg.banded_lu import lu_factor, lu_solve
from ..linalg.cholesky import band_matvec_add, cholesky, cholesky_solve
from ..records import MotionScratch, RunRecord, StepStart
from ..statics.newton import minimize
from ..statics.states import inversion_state

# Rodas3 in the transformed form (as RODAS4_* in .dynamics.rosenbrock):
#   (M/(hγ) - J) K_i = f(t + α_i h, y + Σ_j A_ij K_j) + M Σ_j C_ij K_j / h + γ_i h ∂f/∂t,
#   y_new = y + Σ_j B_j K_j = (stage-4 point) + K_4, error estimate K_4.
RODAS3_GAMMA = 0.5
RODAS3_ALPHA = np.array([0.0, 0.0, 1.0, 1.0])
RODAS3_GAMMA_SUM = np.array([0.5, 1.5, 0.0, 0.0])
RODAS3_A = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 1.0]])
RODAS3_C = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [1.0, -1.0, 0.0], [1.0, -1.0, -8.0 / 3.0]])
RODAS3_B = np.array([2.0, 0.0, 1.0, 1.0])
N_STAGES = 4
#: Order of the embedded solution + 1: the step-size exponent.
ERROR_ORDER = 3.0

#: Controls of the static check's Newton (N, mm, iterations, mm): only the pattern of the
#: minimum matters, not its last digits.
CHECK_GTOL = 1e-4
CHECK_XTOL = 1e-4
CHECK_MAX_ITER = np.int64(60)  # int64, not a literal: see the package docstring
CHECK_MAX_STEP = 0.5

_FAC_MAX = 5.0
#: Reduction after a rejected step whose error estimate is beyond this (a snap inside the step).
_HUGE_ERROR = 1e3
_FAC_HUGE = 0.05

#: Why a release run stopped (``stats[STAT_STOPPED_EARLY]``): at the horizon (the counters'
#: zero, as :func:`.dynamics.events.init_record` leaves them), all reset, the static check.
STOP_HORIZON = 0
STOP_ALL_RESET = 1
STOP_STATIC = 2

#: Per-unit diagnostics (``unit_diag`` columns).
UD_EVENT_STEP = 0  # s, step that held the last downward crossing (NaN: none)
UD_EVENT_ERROR = 1  # its error estimate (1 = the tolerance)
N_RELEASE_DIAG = 2


@kernel
def release_workspace(n_units):
    """Scratch arrays of :func:`release_rodas3` (and its static check) for ``n_units`` units."""
    n = n_free(n_units)
    nodes = n_nodes(n_units)
    return (
        np.empty((nodes, 2)),
        np.empty((nodes, 2)),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty(n, dtype=np.int64),
        np.empty((N_STAGES, n)),
        np.empty((N_STAGES, n)),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n_units),
        np.empty(n_units),
        np.empty(n),
        np.empty(n_units),
        np.empty(n_units),
    )


@kernel
def current_pattern(unit_rec):
    """Inverted units of a run's record as a state integer (unit 1 most significant)."""
    state = 0
    for k in range(unit_rec.shape[0]):
        state = 2 * state + (1 if unit_rec[k, REC_INVERTED] > 0.0 else 0)
    return state


@kernel
def settled_pattern(x, unit_params, h, newton_ws, check_x, check_u, counters):
    """Pattern of the minimum Newton reaches from ``x`` without pressure (-1 if it fails).

    ``counters[0]`` accumulates Hessian evaluations, ``counters[1]`` the checks.
    """
    n = n_free(unit_params.shape[0])
    for i in range(n):
        check_x[i] = x[i]
    status, n_iter = minimize(
        check_x, unit_params, h, CHECK_GTOL, CHECK_XTOL, CHECK_MAX_ITER, CHECK_MAX_STEP, newton_ws
    )
    counters[0] += n_iter
    counters[1] += 1
    if status != st.OK:
        return -1
    return inversion_state(check_x, unit_params, h, newton_ws[0], check_u)


#: The release's workspace (:func:`release_rodas3`): the model, controls and records it was
#: given (``record``: a :class:`~.records.RunRecord` without samples, over ``out``'s event
#: record and counters), the scratch of the right-hand side and of the step start, the stage
#: matrix with its factors, stage residuals, stages and a stage's point and right-hand side,
#: the state ``x``, ``v`` and the step's end ``x_new``, ``v_new``, the event margins, the
#: static check's scratch and Newton workspace, each unit's last downward crossing before a
#: step (``last_down``) and the stop rule's ``memory`` (:data:`MEMORY_CHECK_DUE`,
#: :data:`MEMORY_T_EVENT`).
ReleaseWork = namedtuple(
    "ReleaseWork",
    "model ctrl record out scratch start smat low piv res kx kv yx yv rx x v x_new v_new "
    "g0 g1 check_x check_u last_down newton_ws memory",
)
#: ``memory[MEMORY_CHECK_DUE]``: 1.0 while a static check is due (a crossing happened since the
#: last one); ``memory[MEMORY_T_EVENT]``: the end of the step of the last crossing (s).
MEMORY_CHECK_DUE = 0
MEMORY_T_EVENT = 1


@kernel(inline="always")
def _release_stop(work, t, capped):
    """Past the profile: stop when every unit has reset, or when the static check agrees.

    Checked before the step cap (``capped`` does not matter here).
    """
    unit_params, h, knot_t, _, _ = work.model
    unit_rec, stats, _, counters = work.out
    memory = work.memory
    tau_end = knot_t[knot_t.shape[0] - 1]
    if t >= tau_end:
        if settled_reset(unit_rec, t, tau_end):
            stats[STAT_STOPPED_EARLY] = STOP_ALL_RESET
            return st.OK
        if memory[MEMORY_CHECK_DUE] > 0.0 and t - memory[MEMORY_T_EVENT] >= SETTLE_TIME:
            found = settled_pattern(
                work.x, unit_params, h, work.newton_ws, work.check_x, work.check_u, counters
            )
            if found == current_pattern(unit_rec):
                stats[STAT_STOPPED_EARLY] = STOP_STATIC
                return st.OK
            memory[MEMORY_CHECK_DUE] = 0.0
    return GO_ON


@kernel(inline="always")
def _rodas3_attempt(work, t, step, retry):
    """One overdamped Rodas3 step of ``step`` s from ``(t, x, v)``: ``(ok, err)``."""
    (model, ctrl, record, _, scratch, start, smat, low, piv, res, kx, kv, yx, yv, rx) = work[:15]
    x, v, x_new, v_new = work.x, work.v, work.x_new, work.v_new
    _, _, knot_t, knot_p, _ = model
    res0, jac, cmat, ft = start
    stats = record.stats
    n = x.shape[0]
    if not retry:
        step_start(x, v, t, step, model, scratch, start)
        stats[STAT_RHS] += 1
    inv_hg = 1.0 / (step * RODAS3_GAMMA)
    inv_step = 1.0 / step
    for i in range(n):
        for j in range(n):
            smat[i, j] = cmat[i, j] * inv_hg - jac[i, j]
    stats[STAT_FACTOR] += 1
    use_cholesky = pressure_at(t, knot_t, knot_p) == 0.0 and cholesky(smat, 0.0, low, n)
    ok = use_cholesky or lu_factor(smat, n, piv, BAND) == 0
    err = 0.0
    if ok:
        for s in range(N_STAGES):
            same_point = RODAS3_ALPHA[s] == 0.0
            for i in range(n):
                yx[i] = x[i]
                yv[i] = v[i]
                rx[i] = 0.0
            for j in range(s):
                a_sj = RODAS3_A[s, j]
                c_sj = RODAS3_C[s, j] * inv_step
                if a_sj != 0.0:
                    same_point = False
                for i in range(n):
                    yx[i] += a_sj * kx[j, i]
                    yv[i] += a_sj * kv[j, i]
                    rx[i] += c_sj * kx[j, i]
            for i in range(n):
                rx[i] += yv[i]
            if same_point:  # stages 1 and 2 sit at the step start
                for i in range(n):
                    res[i] = res0[i]
            else:
                force_residual(yx, yv, t + RODAS3_ALPHA[s] * step, model, scratch, res)
                stats[STAT_RHS] += 1
            gam_h = RODAS3_GAMMA_SUM[s] * step
            kx_s = kx[s]
            for i in range(n):
                kx_s[i] = res[i] + gam_h * ft[i]
            band_matvec_add(cmat, rx, n, BAND, kx_s)  # + C r_x (zero mass)
            if use_cholesky:
                cholesky_solve(low, kx_s, kx_s, n)
            else:
                lu_solve(smat, n, piv, kx_s, BAND)
            for i in range(n):
                kv[s, i] = kx_s[i] * inv_hg - rx[i]
        for i in range(n):
            bx = x[i]
            bv = v[i]
            for s in range(N_STAGES):
                bx += RODAS3_B[s] * kx[s, i]
                bv += RODAS3_B[s] * kv[s, i]
            x_new[i] = bx
            v_new[i] = bv
            if not (math.isfinite(bx) and math.isfinite(bv)):
                ok = False
        err = error_norm(kx[N_STAGES - 1], x, x_new, n, ctrl[CTRL_RTOL], ctrl[CTRL_ATOL])
        ok = ok and math.isfinite(err)
    return ok, err


@kernel(inline="always")
def _release_accept(work, t, step, err):
    """:func:`.dynamics.rosenbrock.accept_step`, and the diagnostics of each new crossing.

    A step that holds a unit's new last downward crossing leaves its length and error estimate
    in ``unit_diag``; any crossing makes the static check due again.
    """
    unit_rec, stats, unit_diag, _ = work.out
    last_down = work.last_down
    n_units = unit_rec.shape[0]
    events = stats[STAT_EVENTS]
    for k in range(n_units):
        last_down[k] = unit_rec[k, REC_LAST_DOWN]
    accept_step(work, t, step, err)
    if stats[STAT_EVENTS] != events:
        work.memory[MEMORY_CHECK_DUE] = 1.0
        work.memory[MEMORY_T_EVENT] = t + step
        for k in range(n_units):
            down = unit_rec[k, REC_LAST_DOWN]
            if down == down and down != last_down[k]:  # a new last downward crossing
                unit_diag[k, UD_EVENT_STEP] = step
                unit_diag[k, UD_EVENT_ERROR] = err


@kernel(inline="always")
def _rodas3_accepted_factor(err, step, h_acc, err_acc, last_rejected):
    """:func:`.dynamics.rosenbrock.accepted_step_factor` for order 2 + 1, largest change 5."""
    expo = 1.0 / ERROR_ORDER
    return accepted_step_factor(err, step, h_acc, max(1e-2, err_acc), expo, _FAC_MAX, last_rejected)


@kernel(inline="always")
def _rodas3_rejected_factor(err):
    """The retry's step: ``err^-1/3``, cut harder after a snap inside the step."""
    expo = 1.0 / ERROR_ORDER
    return max(_FAC_HUGE if err > _HUGE_ERROR else FAC_MIN, SAFETY * err**-expo)


_release_steps = step_driver(
    _release_stop,
    _rodas3_attempt,
    _release_accept,
    _rodas3_accepted_factor,
    _rodas3_rejected_factor,
)


@kernel
def release_rodas3(x, model, ctrl, t0, t_end, out, ws, newton_ws):
    """Integrate the overdamped lattice from rest at ``x`` (time ``t0``) until it may stop.

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        Start (an equilibrium under ``P(t0)``); overwritten with the final positions.
    model : MotionModel
        Lattice tables ``unit_params``, ``h`` (:mod:`.layout`, penalties off), the pressure
        profile ``knot_t``, ``knot_p`` (s, MPa; reset times count from its last knot) and
        ``phys`` ``(η, η_iso, 0)`` (N·s/mm; the model is overdamped) (:mod:`.records`).
    ctrl : ndarray of shape (N_CTRL,)
        :mod:`.dynamics.events` controls: ``CTRL_ATOL`` / ``CTRL_RTOL`` on positions, first step,
        largest step, step cap, smallest step.
    t0, t_end : float, s
    out : ReleaseRecord
        Event record ``unit_rec`` and counters ``stats`` (:mod:`.dynamics.events`;
        ``stats[STAT_STOPPED_EARLY]`` receives the ``STOP_*`` reason), per-unit event
        diagnostics ``unit_diag`` (N, N_RELEASE_DIAG; ``UD_*``) and ``counters`` (int64, (2,)):
        static-check Newton iterations and checks.
    ws, newton_ws : tuple
        :func:`release_workspace` and :func:`.statics.newton.workspace`.

    Returns
    -------
    int
        Status: ``OK``, ``STEP_LIMIT``, ``NOT_CONVERGED`` (step below ``CTRL_H_MIN``) or
        ``DEGENERATE_GEOMETRY`` (singular damping matrix at the start).
    """
    (
        pos,
        vel,
        scratch_work,
        res0,
        res,
        jac,
        cmat,
        smat,
        low,
        piv,
        kx,
        kv,
        yx,
        yv,
        rx,
        ft,
        x_new,
        v_new,
        g0,
        g1,
        check_x,
        check_u,
        last_down,
    ) = ws
    unit_params, _, knot_t, _, _ = model
    unit_rec, stats, unit_diag, _ = out
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    scratch = MotionScratch(pos, vel, scratch_work)
    start = StepStart(res0, jac, cmat, ft)
    v = np.empty(n)
    if consistent_velocity(x, t0, model, scratch, cmat, piv, v) != 0:
        return st.DEGENERATE_GEOMETRY
    init_record(x, t0, unit_params, unit_rec, stats, g0)
    for k in range(n_units):
        unit_diag[k, UD_EVENT_STEP] = np.nan
        unit_diag[k, UD_EVENT_ERROR] = np.nan
    record = RunRecord(np.empty(0), np.empty((0, n)), unit_rec, np.empty((0, 3)), stats)
    memory = np.empty(2)
    memory[MEMORY_CHECK_DUE] = 1.0
    memory[MEMORY_T_EVENT] = knot_t[knot_t.shape[0] - 1]
    work = ReleaseWork(
        model,
        ctrl,
        record,
        out,
        scratch,
        start,
        smat,
        low,
        piv,
        res,
        kx,
        kv,
        yx,
        yv,
        rx,
        x,
        v,
        x_new,
        v_new,
        g0,
        g1,
        check_x,
        check_u,
        last_down,
        newton_ws,
        memory,
    )
    step = min(ctrl[CTRL_H_INIT], ctrl[CTRL_H_MAX])
    return _release_steps(work, t0, t_end, step, ctrl, knot_t, stats)
