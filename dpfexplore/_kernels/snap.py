"""Snap pressures: follow a finger's equilibrium under a slow pressure ramp, snap at each fold.

:func:`follow` continues the equilibrium branch from a stable state (:mod:`.continuation`) as the
pressure rises (``sign = +1``) or falls (``-1``), and records two kinds of event:

* a *crossing*: a unit's extension passes its inversion threshold ``u_inv`` smoothly along the
  branch (the state label changes, nothing jumps; e.g. a dome with ``α >= 1/9`` has no barrier
  and its extension just grows through ``u = 3/4``);
* a *snap*: the branch folds (a real eigenvalue of ``K`` crosses zero and the branch turns back
  in pressure). The fold is located to the corrector's tolerance, and the finger's landing is
  decided by the dynamics (:mod:`.landing`): the fold state is kicked along the branch's
  direction of travel and the equations of motion (MODEL.md §8, Rodas4, full or overdamped) run
  at the fold pressure plus a small offset until the motion has settled onto an equilibrium
  that Newton polishes at the fold pressure and certifies stable. The
  continuation resumes from there. A cascade (several units going at once) is one snap whose
  landing differs from the state before it in several units.

Why the fold pressure needs no dynamics but the landing does: in the limit of a slow ramp the
finger follows its stable branch quasi-statically, and inertia and damping only act once that
branch ends; so the pressure of the snap is the fold's (a slow ramp overshoots it by a delay
that vanishes as ``rate^(2/3)``, the passage through a saddle-node), while where the finger comes
to rest depends on how its motion carries it (which units a cascade takes along).

:func:`snap_batch` runs the rising ramp from the flat finger for many designs in parallel and,
for every state visited, the release from where it was entered down to ``P_min``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..model import status as st
from ._jit import batch_kernel, kernel
from .continuation import (
    CORRECT_OK,
    PRESSURE_SCALE,
    WHICH_END,
    WHICH_FOLD,
    correct,
    locate,
    workspace,
)
from .dynamics import PHYS_ETA, PHYS_ETA_ISO
from .dynamics_batch import rest_state
from .events import (
    margins,
)
from .landing import certify_stable, land
from .layout import COL_D, COL_P, COL_U_INV, n_free

# ---- outputs -------------------------------------------------------------------------------

#: Columns of the event table.
EV_P = 0  # pressure, MPa
EV_KIND = 1  # KIND_SNAP or KIND_CROSSING
EV_BEFORE = 2  # state integer before (unit 1 = most significant bit)
EV_AFTER = 3  # state integer after
EV_CERT = 4  # landing's stability certificate (see certify_stable); inf for crossings
EV_SETTLE = 5  # s of motion simulated before the landing was accepted (0 for crossings)
EV_STEPS = 6  # Rodas4 steps of the landing
EV_DP = 7  # MPa past the fold at which the landing's motion settled (0 for crossings)
N_EV = 8

KIND_SNAP = 1
KIND_CROSSING = 2
#: A fold past which the motion did not settle on any equilibrium within the landing's time
#: budget (the walk stops there): the follower load is not conservative, and past some folds
#: of strongly curled fingers the motion is a slow relaxation oscillation instead.
KIND_UNSETTLED = 3

#: Columns of the path table (one row per accepted branch point, fold and landing).
PATH_P = 0  # MPa
PATH_SEGMENT = 1  # branch number: 0 from the start, +1 after each snap
PATH_STATE = 2  # state integer
PATH_TIP_X = 3  # mm
PATH_TIP_Y = 4  # mm
PATH_U = 5  # first of N columns: dome extension over reach, u = x̄/d
N_PATH_FIXED = 5

#: Counters.
CNT_EVENTS = 0  # events found (the table keeps at most its capacity)
CNT_PATH = 1  # path rows found
CNT_STEPS = 2  # accepted continuation steps
CNT_REJECTED = 3  # rejected continuation steps
CNT_LANDING_STEPS = 4  # Rodas4 steps of all landings
N_CNT = 5

# ---- continuation controls -------------------------------------------------------------------

#: First arclength step (mm, scaled) on each branch, largest step, smallest before giving up.
DS_INIT = 0.05
DS_MAX = 4.0
DS_MIN = 1e-9
#: Growth of the step after an easy corrector (at most this many Newton iterations).
DS_GROW = 2.0
EASY_ITER = 3
#: Largest turn of the tangent in one step (rad): keeps the corrector on its own branch.
MAX_TURN = 0.4
#: Largest change of a dome's extension in one step, in units of ``max(d, D_FLOOR)``: a jump to
#: another branch moves some dome by about its reach, and crossings stay resolved.
DU_MAX = 0.1
D_FLOOR = 0.1
#: Continuation steps (accepted + rejected) per branch walk.
MAX_STEPS = 20000


@kernel
def state_of(g, n_units):
    """State integer from unit margins ``g = u - u_inv`` (unit 1 = most significant bit)."""
    state = 0
    for k in range(n_units):
        state = 2 * state + (1 if g[k] > 0.0 else 0)
    return state


@kernel
def _record_path(y, segment, state, unit_params, h, g, path, counts):
    """Append branch point ``y`` (scaled) to ``path`` if there is room; count it anyway."""
    row = counts[CNT_PATH]
    counts[CNT_PATH] += 1
    if row >= path.shape[0]:
        return
    n_units = unit_params.shape[0]
    n = y.shape[0] - 1
    path[row, PATH_P] = y[n] / PRESSURE_SCALE
    path[row, PATH_SEGMENT] = segment
    path[row, PATH_STATE] = state
    if n_units == 1:  # the tip L_1 is clamped
        path[row, PATH_TIP_X] = unit_params[0, COL_P]
        path[row, PATH_TIP_Y] = h
    else:
        path[row, PATH_TIP_X] = y[n - 2]
        path[row, PATH_TIP_Y] = y[n - 1]
    margins(y[:n], unit_params, g)
    for k in range(n_units):
        path[row, PATH_U + k] = g[k] + unit_params[k, COL_U_INV]


@kernel
def _add_event(ev, ev_x, counts, pressure, kind, before, after, x_before, x_after, info):
    """Append an event; returns False when the table is full."""
    j = counts[CNT_EVENTS]
    if j >= ev.shape[0]:
        return False
    counts[CNT_EVENTS] += 1
    ev[j, EV_P] = pressure
    ev[j, EV_KIND] = kind
    ev[j, EV_BEFORE] = before
    ev[j, EV_AFTER] = after
    ev[j, EV_CERT] = info[0]
    ev[j, EV_SETTLE] = info[1]
    ev[j, EV_STEPS] = info[2]
    ev[j, EV_DP] = info[4]
    if ev_x.shape[0] > j:
        for i in range(x_before.shape[0]):
            ev_x[j, 0, i] = x_before[i]
            ev_x[j, 1, i] = x_after[i]
    return True


@kernel
def follow(
    unit_params, h, x_start, p_start, p_end, sign, phys, ctrl, kick, ev, ev_x, path, counts, x_final
):
    """Follow the equilibrium from ``(x_start, p_start)`` to ``p_end``, snapping at folds.

    Parameters
    ----------
    unit_params, h
        Lattice parameters (:mod:`.layout`).
    x_start : ndarray of shape (4N - 2,), mm
        A stable equilibrium at ``p_start`` (polished here).
    p_start, p_end : float, MPa
    sign : int
        +1: rising pressure (``p_end > p_start``), -1: falling.
    phys, ctrl
        Model and Rodas4 controls of the landings (:mod:`.dynamics`, :mod:`.events`).
    kick : float, mm
        First displacement of each landing along the fold's null direction (:func:`land`);
        ``<= 0``: :func:`default_kick`.
    ev : ndarray of shape (capacity, N_EV)
        Receives the events in order (``EV_*`` columns).
    ev_x : ndarray of shape (capacity, 2, 4N - 2) or (0, 2, 4N - 2)
        Receives each event's shape before and after (skipped if empty).
    path : ndarray of shape (rows, N_PATH_FIXED + N)
        Receives the branch points (``PATH_*`` columns), as many as fit.
    counts : ndarray of int64, shape (N_CNT,)
        Filled with the ``CNT_*`` counters.
    x_final : ndarray of shape (4N - 2,)
        The equilibrium at ``p_end`` (or where the walk stopped).

    Returns
    -------
    int
        ``OK``; ``NOT_CONVERGED`` (a step or a landing failed), ``STEP_LIMIT`` (step cap or
        event table full), ``UNSTABLE`` (the start is not a stable equilibrium),
        ``DEGENERATE_GEOMETRY`` or ``NONFINITE``.
    """
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    ws = workspace(n_units)
    for i in range(N_CNT):
        counts[i] = 0
    y0 = np.empty(n + 1)
    t0 = np.empty(n + 1)
    y1 = np.empty(n + 1)
    t1 = np.empty(n + 1)
    yb = np.empty(n + 1)  # the point where this step stops (fold or end)
    tb = np.empty(n + 1)
    yc = np.empty(n + 1)  # scratch for located crossings
    tc = np.empty(n + 1)
    border = np.zeros(n + 1)
    border[n] = sign
    g0 = np.empty(n_units)
    g1 = np.empty(n_units)
    gb = np.empty(n_units)
    gp = np.empty(n_units)  # scratch of the path recorder
    d_scale = np.empty(n_units)
    for k in range(n_units):
        d_scale[k] = max(1.0, D_FLOOR / unit_params[k, COL_D])
    cross_s = np.empty(n_units)
    cross_x = np.empty((n_units, n + 1))
    cross_k = np.empty(n_units, dtype=np.int64)
    x_land = np.empty(n)
    info = np.zeros(5)
    p_end_s = p_end * PRESSURE_SCALE

    for i in range(n):
        y1[i] = x_start[i]
        x_final[i] = x_start[i]
    y1[n] = p_start * PRESSURE_SCALE
    code, _ = correct(y1, border, 0.0, unit_params, h, ws, y0, t0)
    if code != CORRECT_OK:
        return st.NOT_CONVERGED
    if (
        not certify_stable(y0[:n], p_start, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO])
        > 0.0
    ):
        for i in range(n):
            x_final[i] = y0[i]
        return st.UNSTABLE
    margins(y0[:n], unit_params, g0)
    label = state_of(g0, n_units)
    segment = 0
    _record_path(y0, segment, label, unit_params, h, gp, path, counts)
    if sign * (y0[n] - p_end_s) >= 0.0:
        for i in range(n):
            x_final[i] = y0[i]
        return st.OK
    ds = DS_INIT
    cos_turn = math.cos(MAX_TURN)
    while True:
        for i in range(n):
            x_final[i] = y0[i]
        if counts[CNT_STEPS] + counts[CNT_REJECTED] >= MAX_STEPS:
            return st.STEP_LIMIT
        code, iters = correct(y0, t0, ds, unit_params, h, ws, y1, t1)
        accept = code == CORRECT_OK
        if accept:
            turn = 0.0
            for i in range(n + 1):
                turn += t0[i] * t1[i]
            accept = turn >= cos_turn
        if accept:
            margins(y1[:n], unit_params, g1)
            for k in range(n_units):
                if abs(g1[k] - g0[k]) > DU_MAX * d_scale[k]:
                    accept = False
        if not accept:
            counts[CNT_REJECTED] += 1
            ds *= 0.5
            if ds < DS_MIN:
                return st.NOT_CONVERGED
            continue
        counts[CNT_STEPS] += 1

        # Where does this step stop: at a fold, at the end of the ramp, or not at all? An
        # event that cannot be located (a corrector inside the step that does not converge, on
        # a sharply curved branch) rejects the step: a shorter one brackets it closer.
        failed = False
        stop = 0  # 0 none, 1 fold, 2 end
        s_stop = ds
        if sign * t1[n] < 0.0:
            code, s_stop = locate(
                WHICH_FOLD, y0, t0, 0.0, t0[n], ds, t1[n], unit_params, h, p_end_s, ws, yb, tb
            )
            failed = code != CORRECT_OK
            stop = 1
            p_last = yb[n]  # pressure is monotone up to the fold
        else:
            p_last = y1[n]
        if not failed and sign * (p_last - p_end_s) >= 0.0:
            g_end = p_last - p_end_s
            code, s_stop = locate(
                WHICH_END,
                y0,
                t0,
                0.0,
                y0[n] - p_end_s,
                s_stop,
                g_end,
                unit_params,
                h,
                p_end_s,
                ws,
                yb,
                tb,
            )
            failed = code != CORRECT_OK
            stop = 2
        if not failed and stop != 0:
            margins(yb[:n], unit_params, gb)
        elif not failed:
            for k in range(n_units):
                gb[k] = g1[k]

        # Smooth threshold crossings before the stop point, in arclength order.
        n_cross = 0
        for k in range(n_units):
            if failed or (g0[k] > 0.0) == (gb[k] > 0.0):
                continue
            code, s = locate(
                k, y0, t0, 0.0, g0[k], s_stop, gb[k], unit_params, h, p_end_s, ws, yc, tc
            )
            if code != CORRECT_OK:
                failed = True
                continue
            j = n_cross
            while j > 0 and cross_s[j - 1] > s:
                cross_s[j] = cross_s[j - 1]
                cross_k[j] = cross_k[j - 1]
                for i in range(n + 1):
                    cross_x[j, i] = cross_x[j - 1, i]
                j -= 1
            cross_s[j] = s
            cross_k[j] = k
            for i in range(n + 1):
                cross_x[j, i] = yc[i]
            n_cross += 1
        if failed:
            counts[CNT_STEPS] -= 1
            counts[CNT_REJECTED] += 1
            ds *= 0.5
            if ds < DS_MIN:
                return st.NOT_CONVERGED
            continue
        if stop != 0:
            for i in range(n + 1):
                y1[i] = yb[i]
                t1[i] = tb[i]
        info[0] = np.inf
        info[1] = 0.0
        info[2] = 0.0
        info[4] = 0.0
        for j in range(n_cross):
            bit = 1 << (n_units - 1 - cross_k[j])
            after = label ^ bit
            if not _add_event(
                ev,
                ev_x,
                counts,
                cross_x[j, n] / PRESSURE_SCALE,
                KIND_CROSSING,
                label,
                after,
                cross_x[j, :n],
                cross_x[j, :n],
                info,
            ):
                return st.STEP_LIMIT
            label = after
            _record_path(cross_x[j], segment, label, unit_params, h, gp, path, counts)

        if stop == 2:
            _record_path(y1, segment, label, unit_params, h, gp, path, counts)
            for i in range(n):
                x_final[i] = y1[i]
            return st.OK
        if stop == 1:
            _record_path(y1, segment, label, unit_params, h, gp, path, counts)
            p_fold = y1[n] / PRESSURE_SCALE
            code = land(
                y1[:n], t1[:n], p_fold, sign, unit_params, h, phys, ctrl, kick, x_land, info
            )
            counts[CNT_LANDING_STEPS] += int(info[2])
            if code != st.OK:
                for i in range(n):
                    x_final[i] = y1[i]
                if code == st.NOT_CONVERGED:
                    info[0] = np.nan
                    _add_event(
                        ev, ev_x, counts, p_fold, KIND_UNSETTLED, label, -1, y1[:n], y1[:n], info
                    )
                return code
            margins(x_land, unit_params, g0)
            after = state_of(g0, n_units)
            if not _add_event(
                ev, ev_x, counts, p_fold, KIND_SNAP, label, after, y1[:n], x_land, info
            ):
                return st.STEP_LIMIT
            label = after
            segment += 1
            for i in range(n):
                y1[i] = x_land[i]
            code, _ = correct(y1, border, 0.0, unit_params, h, ws, y0, t0)
            if code != CORRECT_OK:
                return st.NOT_CONVERGED
            margins(y0[:n], unit_params, g0)
            _record_path(y0, segment, label, unit_params, h, gp, path, counts)
            ds = DS_INIT
            continue
        for i in range(n + 1):
            y0[i] = y1[i]
            t0[i] = t1[i]
        for k in range(n_units):
            g0[k] = g1[k]
        _record_path(y0, segment, label, unit_params, h, gp, path, counts)
        if iters <= EASY_ITER:
            ds = min(ds * DS_GROW, DS_MAX)


@batch_kernel
def snap_batch(
    unit_params,
    h,
    n_units,
    valid,
    p_max,
    p_min,
    release,
    phys_eta,
    phys_eta_iso,
    overdamped,
    mass_per_unit,
    ctrl,
    kick,
    status,
    n_events,
    events,
    release_status,
    release_state,
    release_p,
):
    """The rising ramp from the flat finger, and each visited state's release, for many designs.

    Parameters
    ----------
    unit_params, h, n_units, valid
        Padded batch tables (:func:`dpfexplore.solvers.lattice.pack_batch`) and which rows to run.
    p_max, p_min : float, MPa
        End of the rising ramp; end of every release.
    release : bool
        Also follow each visited state down to ``p_min``.
    phys_eta, phys_eta_iso, overdamped, mass_per_unit
        Model of the landings (damping, N·s/mm; inertia dropped or node masses of
        ``mass_per_unit · N / (2N + 2)`` tonne).
    ctrl : ndarray
        Rodas4 controls of the landings.
    kick : float, mm
        See :func:`follow` (``<= 0``: :func:`default_kick`).
    status, n_events : ndarray of shape (n,)
        Status of the rising walk and its number of events (int64).
    events : ndarray of shape (n, capacity, N_EV)
        The rising walk's events.
    release_status, release_state, release_p : ndarray of shape (n, capacity + 1)
        For visited state ``j`` (0 = the flat start, ``j`` = after event ``j - 1``): status of
        its release, the state it ends in at ``p_min`` and the pressure of the first event on
        the way down (NaN: none, the state lasts down to ``p_min``).

    Notes
    -----
    A state entered by a smooth crossing lies on the same branch as the state before it, so its
    release retraces the crossing (its first event on the way down) and then that state's
    release: only the start and each landing need a walk of their own.
    """
    n = unit_params.shape[0]
    capacity = events.shape[1]
    for i in prange(n):
        if not valid[i]:
            continue
        nu = n_units[i]
        params = unit_params[i, :nu]
        nf = n_free(nu)
        phys = np.empty(3)
        phys[0] = phys_eta
        phys[1] = phys_eta_iso
        phys[2] = 0.0 if overdamped else mass_per_unit * nu / (2.0 * nu + 2.0)
        y = np.empty(2 * nf)
        rest_state(params, h[i], y)
        ev_x = np.empty((capacity, 2, nf))
        path = np.empty((0, N_PATH_FIXED + nu))
        counts = np.zeros(N_CNT, dtype=np.int64)
        x_final = np.empty(nf)
        code = follow(
            params,
            h[i],
            y[:nf],
            0.0,
            p_max,
            1,
            phys,
            ctrl,
            kick,
            events[i],
            ev_x,
            path,
            counts,
            x_final,
        )
        status[i] = code
        ne = min(counts[CNT_EVENTS], capacity)
        n_events[i] = ne
        if ne > 0 and events[i, ne - 1, EV_KIND] == KIND_UNSETTLED:
            ne -= 1  # no state after it to release
        if release:
            release_walks(
                params,
                h[i],
                y[:nf],
                0.0,
                events[i],
                ev_x,
                ne,
                p_min,
                phys,
                ctrl,
                kick,
                release_status[i],
                release_state[i],
                release_p[i],
            )


@kernel
def release_walks(
    unit_params,
    h,
    x_start,
    p_start,
    ev,
    ev_x,
    n_events,
    p_min,
    phys,
    ctrl,
    kick,
    release_status,
    release_state,
    release_p,
):
    """Release each state of a rising walk (start, then ``ev``) down to ``p_min``.

    The walk started at ``(x_start, p_start)``. Fills entry ``j`` (0 = the start, ``j`` = the
    state after event ``j - 1``) of ``release_status``, ``release_state`` and ``release_p``
    (see :func:`snap_batch`).
    """
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    capacity = ev.shape[0]
    ev2 = np.empty((capacity, N_EV))
    ev2_x = np.empty((0, 2, nf))
    path = np.empty((0, N_PATH_FIXED + n_units))
    counts = np.zeros(N_CNT, dtype=np.int64)
    x_final = np.empty(nf)
    g = np.empty(n_units)
    x_entry = np.empty(nf)
    for j in range(n_events + 1):
        if j > 0 and ev[j - 1, EV_KIND] == KIND_CROSSING:
            release_status[j] = release_status[j - 1]
            release_state[j] = release_state[j - 1]
            release_p[j] = ev[j - 1, EV_P]
            continue
        if j == 0:
            p_entry = p_start
            for i in range(nf):
                x_entry[i] = x_start[i]
        else:
            p_entry = ev[j - 1, EV_P]
            for i in range(nf):
                x_entry[i] = ev_x[j - 1, 1, i]
        code = follow(
            unit_params,
            h,
            x_entry,
            p_entry,
            p_min,
            -1,
            phys,
            ctrl,
            kick,
            ev2,
            ev2_x,
            path,
            counts,
            x_final,
        )
        release_status[j] = code
        margins(x_final, unit_params, g)
        release_state[j] = state_of(g, n_units) if code == st.OK else -1
        release_p[j] = ev2[0, EV_P] if counts[CNT_EVENTS] > 0 else np.nan
