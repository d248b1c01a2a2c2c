"""The stages of one snap walk's continuation step, as kernels of their own.

:func:`.snap.follow` runs them in order on every step: a trial step (:func:`trial_step`),
where it stops (:func:`step_stop`: a fold or the end of the ramp), the smooth crossings before
that (:func:`crossings`), their events (:func:`record_crossings`) and, at a fold, the landing
(:func:`snap`). They read and write the walk's scratch and outputs by name
(:mod:`.snap_records`). The controls of the continuation are here.
"""

from __future__ import annotations

import numpy as np

from ..model import status as st
from ._jit import kernel
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
from .events import margins
from .landing import (
    LAND_CERT,
    LAND_OFFSET,
    LAND_SECONDS,
    LAND_STEPS,
    N_LAND_INFO,
    certify_stable,
    land,
)
from .layout import COL_D, COL_P, COL_U_INV, n_free
from .snap_records import (
    CNT_EVENTS,
    CNT_LANDING_STEPS,
    CNT_PATH,
    EV_AFTER,
    EV_BEFORE,
    EV_CERT,
    EV_DP,
    EV_KIND,
    EV_P,
    EV_SETTLE,
    EV_STEPS,
    KIND_CROSSING,
    KIND_SNAP,
    KIND_UNSETTLED,
    PATH_P,
    PATH_SEGMENT,
    PATH_STATE,
    PATH_TIP_X,
    PATH_TIP_Y,
    PATH_U,
    FollowScratch,
)

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
#: Where a step stops (:func:`_step_stop`): nowhere, at a fold, at the end of the ramp.
STOP_NONE = 0
STOP_FOLD = 1
STOP_END = 2


@kernel
def state_of(g, n_units):
    """State integer from unit margins ``g = u - u_inv`` (unit 1 = most significant bit)."""
    state = 0
    for k in range(n_units):
        state = 2 * state + (1 if g[k] > 0.0 else 0)
    return state


@kernel
def record_path(y, segment, state, unit_params, h, g, path, counts):
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
def add_event(out, pressure, kind, before, after, x_before, x_after, info):
    """Append an event to ``out``; returns False when the table is full."""
    ev, ev_x, counts = out.ev, out.ev_x, out.counts
    j = counts[CNT_EVENTS]
    if j >= ev.shape[0]:
        return False
    counts[CNT_EVENTS] += 1
    ev[j, EV_P] = pressure
    ev[j, EV_KIND] = kind
    ev[j, EV_BEFORE] = before
    ev[j, EV_AFTER] = after
    ev[j, EV_CERT] = info[LAND_CERT]
    ev[j, EV_SETTLE] = info[LAND_SECONDS]
    ev[j, EV_STEPS] = info[LAND_STEPS]
    ev[j, EV_DP] = info[LAND_OFFSET]
    if ev_x.shape[0] > j:
        for i in range(x_before.shape[0]):
            ev_x[j, 0, i] = x_before[i]
            ev_x[j, 1, i] = x_after[i]
    return True


@kernel
def scratch(unit_params, sign):
    """A walk's scratch (:data:`FollowScratch`) for a lattice of ``unit_params``."""
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    border = np.zeros(n + 1)
    border[n] = sign
    d_scale = np.empty(n_units)
    for k in range(n_units):
        d_scale[k] = max(1.0, D_FLOOR / unit_params[k, COL_D])
    return FollowScratch(
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        np.empty(n + 1),
        border,
        np.empty(n_units),
        np.empty(n_units),
        np.empty(n_units),
        np.empty(n_units),
        d_scale,
        np.empty(n_units),
        np.empty(n_units, dtype=np.int64),
        np.empty((n_units, n + 1)),
        np.empty(n),
        np.zeros(N_LAND_INFO),
        workspace(n_units),
    )


@kernel
def start(x_start, p_start, unit_params, h, phys, s):
    """Polish the start onto the branch (``s.y0``, ``s.t0``) and certify it stable.

    Returns ``OK``, ``NOT_CONVERGED`` (no equilibrium there) or ``UNSTABLE``.
    """
    n = x_start.shape[0]
    for i in range(n):
        s.y1[i] = x_start[i]
    s.y1[n] = p_start * PRESSURE_SCALE
    code, _ = correct(s.y1, s.border, 0.0, unit_params, h, s.ws, s.y0, s.t0)
    if code != CORRECT_OK:
        return st.NOT_CONVERGED
    cert = certify_stable(s.y0[:n], p_start, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO])
    if not cert > 0.0:
        return st.UNSTABLE
    return st.OK


@kernel
def trial_step(ds, cos_turn, unit_params, h, s):
    """Predict and correct a step of arclength ``ds`` into ``s.y1``, ``s.t1``, ``s.g1``.

    The step is refused when the corrector fails, the tangent turns by more than
    :data:`MAX_TURN` or a unit's margin moves by more than :data:`DU_MAX` (scaled).
    Returns ``(accepted, corrector iterations)``.
    """
    n_units = unit_params.shape[0]
    n = s.y0.shape[0] - 1
    code, iters = correct(s.y0, s.t0, ds, unit_params, h, s.ws, s.y1, s.t1)
    if code != CORRECT_OK:
        return False, iters
    turn = 0.0
    for i in range(n + 1):
        turn += s.t0[i] * s.t1[i]
    if turn < cos_turn:
        return False, iters
    margins(s.y1[:n], unit_params, s.g1)
    for k in range(n_units):
        if abs(s.g1[k] - s.g0[k]) > DU_MAX * s.d_scale[k]:
            return False, iters
    return True, iters


@kernel
def step_stop(ds, sign, p_end_s, unit_params, h, s):
    """Where an accepted step stops: at a fold, at the end of the ramp, or not at all.

    A stop is located into ``s.yb``, ``s.tb``; ``s.gb`` gets the margins where the step stops
    (the step's end if nowhere before). Returns ``(failed, stop, s_stop)``: ``stop`` 0 none,
    :data:`STOP_FOLD` or :data:`STOP_END`; ``failed`` when a stop could not be located.
    """
    n_units = unit_params.shape[0]
    n = s.y0.shape[0] - 1
    failed = False
    stop = STOP_NONE
    s_stop = ds
    if sign * s.t1[n] < 0.0:
        code, s_stop = locate(
            WHICH_FOLD,
            s.y0,
            s.t0,
            0.0,
            s.t0[n],
            ds,
            s.t1[n],
            unit_params,
            h,
            p_end_s,
            s.ws,
            s.yb,
            s.tb,
        )
        failed = code != CORRECT_OK
        stop = STOP_FOLD
        p_last = s.yb[n]  # pressure is monotone up to the fold
    else:
        p_last = s.y1[n]
    if not failed and sign * (p_last - p_end_s) >= 0.0:
        g_end = p_last - p_end_s
        code, s_stop = locate(
            WHICH_END,
            s.y0,
            s.t0,
            0.0,
            s.y0[n] - p_end_s,
            s_stop,
            g_end,
            unit_params,
            h,
            p_end_s,
            s.ws,
            s.yb,
            s.tb,
        )
        failed = code != CORRECT_OK
        stop = STOP_END
    if not failed and stop != STOP_NONE:
        margins(s.yb[:n], unit_params, s.gb)
    elif not failed:
        for k in range(n_units):
            s.gb[k] = s.g1[k]
    return failed, stop, s_stop


@kernel
def crossings(s_stop, p_end_s, unit_params, h, s):
    """Smooth threshold crossings before the stop point, sorted by arclength into ``s.cross_*``.

    Returns ``(failed, number of crossings)``; ``failed`` when one could not be located.
    """
    n_units = unit_params.shape[0]
    n = s.y0.shape[0] - 1
    n_cross = 0
    for k in range(n_units):
        if (s.g0[k] > 0.0) == (s.gb[k] > 0.0):
            continue
        code, arc = locate(
            k, s.y0, s.t0, 0.0, s.g0[k], s_stop, s.gb[k], unit_params, h, p_end_s, s.ws, s.yc, s.tc
        )
        if code != CORRECT_OK:
            return True, n_cross
        j = n_cross
        while j > 0 and s.cross_s[j - 1] > arc:
            s.cross_s[j] = s.cross_s[j - 1]
            s.cross_k[j] = s.cross_k[j - 1]
            for i in range(n + 1):
                s.cross_x[j, i] = s.cross_x[j - 1, i]
            j -= 1
        s.cross_s[j] = arc
        s.cross_k[j] = k
        for i in range(n + 1):
            s.cross_x[j, i] = s.yc[i]
        n_cross += 1
    return False, n_cross


@kernel
def record_crossings(n_cross, label, segment, unit_params, h, out, s):
    """Add the step's crossings as events (and path points). Returns ``(room left, label)``."""
    n_units = unit_params.shape[0]
    n = s.y0.shape[0] - 1
    for j in range(n_cross):
        bit = 1 << (n_units - 1 - s.cross_k[j])
        after = label ^ bit
        x = s.cross_x[j, :n]
        pressure = s.cross_x[j, n] / PRESSURE_SCALE
        if not add_event(out, pressure, KIND_CROSSING, label, after, x, x, s.info):
            return False, label
        label = after
        record_path(s.cross_x[j], segment, label, unit_params, h, s.gp, out.path, out.counts)
    return True, label


@kernel
def snap(label, segment, sign, unit_params, h, landing, out, s):
    """Land from the fold at ``s.y1``, add the snap, restart the branch from the landing.

    Returns ``(status, label, segment)``: ``OK`` with the state and branch after the snap;
    otherwise the walk ends (an unsettled landing is added as an event first).
    """
    n_units = unit_params.shape[0]
    n = s.y0.shape[0] - 1
    record_path(s.y1, segment, label, unit_params, h, s.gp, out.path, out.counts)
    p_fold = s.y1[n] / PRESSURE_SCALE
    x_fold = s.y1[:n]
    code = land(
        x_fold,
        s.t1[:n],
        p_fold,
        sign,
        unit_params,
        h,
        landing.phys,
        landing.ctrl,
        landing.kick,
        s.x_land,
        s.info,
    )
    out.counts[CNT_LANDING_STEPS] += int(s.info[LAND_STEPS])
    if code != st.OK:
        for i in range(n):
            out.x_final[i] = s.y1[i]
        if code == st.NOT_CONVERGED:
            s.info[LAND_CERT] = np.nan
            add_event(out, p_fold, KIND_UNSETTLED, label, -1, x_fold, x_fold, s.info)
        return code, label, segment
    margins(s.x_land, unit_params, s.g0)
    after = state_of(s.g0, n_units)
    if not add_event(out, p_fold, KIND_SNAP, label, after, x_fold, s.x_land, s.info):
        return st.STEP_LIMIT, label, segment
    label = after
    segment += 1
    for i in range(n):
        s.y1[i] = s.x_land[i]
    code, _ = correct(s.y1, s.border, 0.0, unit_params, h, s.ws, s.y0, s.t0)
    if code != CORRECT_OK:
        return st.NOT_CONVERGED, label, segment
    margins(s.y0[:n], unit_params, s.g0)
    record_path(s.y0, segment, label, unit_params, h, s.gp, out.path, out.counts)
    return st.OK, label, segment
