"""The stages of one snap walk's continuation step, as kernels of their own.

:func:`.snap.walk.follow` runs them in order on every step: a trial step (:func:`trial_step`),
where it stops (:func:`step_stop`: a fold or the end of the ramp), the smooth crossings before
that (:func:`crossings`), their events (:func:`record_crossings`) and, at a fold, the landing
(:func:`snap`). They read and write the walk's scratch and outputs by name
(:mod:`.snap.records`). The controls of the continuation are here.

The stages are inlined into the walk (``inline="always"``, Numba IR inlining): as separate
calls, handing the scratch record across each call cost 10-15 % of a small finger's walk.
"""

from __future__ import annotations

import numpy as np

from ...model import status as st
from .._jit import kernel
from ..dynamics.events import margins
from ..dynamics.motion import PHYS_ETA, PHYS_ETA_ISO
from ..layout import COL_D, COL_P, COL_U_INV, n_free
from ..records import Bracket, BranchPoint, Lattice
from .continuation import (
    CORRECT_OK,
    PRESSURE_SCALE,
    WHICH_END,
    WHICH_FOLD,
    correct,
    locate,
    workspace,
)
from .landing import (
    LAND_CERT,
    LAND_OFFSET,
    LAND_SECONDS,
    LAND_STEPS,
    N_LAND_INFO,
    certify_stable,
    land,
)
from .records import (
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


@kernel(inline="always")
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


@kernel(inline="always")
def start(x_start, p_start, unit_params, h, phys, s):
    """Polish the start onto the branch (``s.y0``, ``s.t0``) and certify it stable.

    Returns ``OK``, ``NOT_CONVERGED`` (no equilibrium there) or ``UNSTABLE``.
    """
    y1, border, ws, y0, t0 = s.y1, s.border, s.ws, s.y0, s.t0
    n = x_start.shape[0]
    for i in range(n):
        y1[i] = x_start[i]
    y1[n] = p_start * PRESSURE_SCALE
    code, _ = correct(y1, border, 0.0, unit_params, h, ws, y0, t0)
    if code != CORRECT_OK:
        return st.NOT_CONVERGED
    cert = certify_stable(y0[:n], p_start, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO])
    if not cert > 0.0:
        return st.UNSTABLE
    return st.OK


@kernel(inline="always")
def trial_step(ds, cos_turn, unit_params, h, s):
    """Predict and correct a step of arclength ``ds`` into ``s.y1``, ``s.t1``, ``s.g1``.

    The step is refused when the corrector fails, the tangent turns by more than
    :data:`MAX_TURN` or a unit's margin moves by more than :data:`DU_MAX` (scaled).
    Returns ``(accepted, corrector iterations)``.
    """
    y0, t0, ws, y1, t1, g1, g0, d_scale = s.y0, s.t0, s.ws, s.y1, s.t1, s.g1, s.g0, s.d_scale
    n_units = unit_params.shape[0]
    n = y0.shape[0] - 1
    code, iters = correct(y0, t0, ds, unit_params, h, ws, y1, t1)
    if code != CORRECT_OK:
        return False, iters
    turn = 0.0
    for i in range(n + 1):
        turn += t0[i] * t1[i]
    if turn < cos_turn:
        return False, iters
    margins(y1[:n], unit_params, g1)
    for k in range(n_units):
        if abs(g1[k] - g0[k]) > DU_MAX * d_scale[k]:
            return False, iters
    return True, iters


@kernel(inline="always")
def step_stop(ds, sign, p_end_s, unit_params, h, s):
    """Where an accepted step stops: at a fold, at the end of the ramp, or not at all.

    A stop is located into ``s.yb``, ``s.tb``; ``s.gb`` gets the margins where the step stops
    (the step's end if nowhere before). Returns ``(failed, stop, s_stop)``: ``stop`` 0 none,
    :data:`STOP_FOLD` or :data:`STOP_END`; ``failed`` when a stop could not be located.
    """
    y0, t1, t0, ws, yb, tb, y1, gb, g1 = s.y0, s.t1, s.t0, s.ws, s.yb, s.tb, s.y1, s.gb, s.g1
    n_units = unit_params.shape[0]
    n = y0.shape[0] - 1
    failed = False
    stop = STOP_NONE
    s_stop = ds
    if sign * t1[n] < 0.0:
        code, s_stop = locate(
            WHICH_FOLD,
            BranchPoint(y0, t0),
            Bracket(0.0, t0[n], ds, t1[n]),
            Lattice(unit_params, h),
            p_end_s,
            ws,
            BranchPoint(yb, tb),
        )
        failed = code != CORRECT_OK
        stop = STOP_FOLD
        p_last = yb[n]  # pressure is monotone up to the fold
    else:
        p_last = y1[n]
    if not failed and sign * (p_last - p_end_s) >= 0.0:
        g_end = p_last - p_end_s
        code, s_stop = locate(
            WHICH_END,
            BranchPoint(y0, t0),
            Bracket(0.0, y0[n] - p_end_s, s_stop, g_end),
            Lattice(unit_params, h),
            p_end_s,
            ws,
            BranchPoint(yb, tb),
        )
        failed = code != CORRECT_OK
        stop = STOP_END
    if not failed and stop != STOP_NONE:
        margins(yb[:n], unit_params, gb)
    elif not failed:
        for k in range(n_units):
            gb[k] = g1[k]
    return failed, stop, s_stop


@kernel(inline="always")
def crossings(s_stop, p_end_s, unit_params, h, s):
    """Smooth threshold crossings before the stop point, sorted by arclength into ``s.cross_*``.

    Returns ``(failed, number of crossings)``; ``failed`` when one could not be located.
    """
    y0, g0, gb, t0, ws, yc, tc, cross_s, cross_k, cross_x = (
        s.y0,
        s.g0,
        s.gb,
        s.t0,
        s.ws,
        s.yc,
        s.tc,
        s.cross_s,
        s.cross_k,
        s.cross_x,
    )
    n_units = unit_params.shape[0]
    n = y0.shape[0] - 1
    n_cross = 0
    for k in range(n_units):
        if (g0[k] > 0.0) == (gb[k] > 0.0):
            continue
        code, arc = locate(
            k,
            BranchPoint(y0, t0),
            Bracket(0.0, g0[k], s_stop, gb[k]),
            Lattice(unit_params, h),
            p_end_s,
            ws,
            BranchPoint(yc, tc),
        )
        if code != CORRECT_OK:
            return True, n_cross
        j = n_cross
        while j > 0 and cross_s[j - 1] > arc:
            cross_s[j] = cross_s[j - 1]
            cross_k[j] = cross_k[j - 1]
            for i in range(n + 1):
                cross_x[j, i] = cross_x[j - 1, i]
            j -= 1
        cross_s[j] = arc
        cross_k[j] = k
        for i in range(n + 1):
            cross_x[j, i] = yc[i]
        n_cross += 1
    return False, n_cross


@kernel(inline="always")
def record_crossings(n_cross, label, segment, unit_params, h, out, s):
    """Add the step's crossings as events (and path points). Returns ``(room left, label)``."""
    y0, cross_k, cross_x, info, gp = s.y0, s.cross_k, s.cross_x, s.info, s.gp
    path, counts = out.path, out.counts
    n_units = unit_params.shape[0]
    n = y0.shape[0] - 1
    for j in range(n_cross):
        bit = 1 << (n_units - 1 - cross_k[j])
        after = label ^ bit
        x = cross_x[j, :n]
        pressure = cross_x[j, n] / PRESSURE_SCALE
        if not add_event(out, pressure, KIND_CROSSING, label, after, x, x, info):
            return False, label
        label = after
        record_path(cross_x[j], segment, label, unit_params, h, gp, path, counts)
    return True, label


@kernel(inline="always")
def snap(label, segment, sign, unit_params, h, landing, out, s):
    """Land from the fold at ``s.y1``, add the snap, restart the branch from the landing.

    Returns ``(status, label, segment)``: ``OK`` with the state and branch after the snap;
    otherwise the walk ends (an unsettled landing is added as an event first).
    """
    y0, y1, gp, t1, x_land, info, g0, border, ws, t0 = (
        s.y0,
        s.y1,
        s.gp,
        s.t1,
        s.x_land,
        s.info,
        s.g0,
        s.border,
        s.ws,
        s.t0,
    )
    path, counts, x_final = out.path, out.counts, out.x_final
    n_units = unit_params.shape[0]
    n = y0.shape[0] - 1
    record_path(y1, segment, label, unit_params, h, gp, path, counts)
    p_fold = y1[n] / PRESSURE_SCALE
    x_fold = y1[:n]
    code = land(x_fold, t1[:n], p_fold, sign, Lattice(unit_params, h), landing, x_land, info)
    counts[CNT_LANDING_STEPS] += int(info[LAND_STEPS])
    if code != st.OK:
        for i in range(n):
            x_final[i] = y1[i]
        if code == st.NOT_CONVERGED:
            info[LAND_CERT] = np.nan
            add_event(out, p_fold, KIND_UNSETTLED, label, -1, x_fold, x_fold, info)
        return code, label, segment
    margins(x_land, unit_params, g0)
    after = state_of(g0, n_units)
    if not add_event(out, p_fold, KIND_SNAP, label, after, x_fold, x_land, info):
        return st.STEP_LIMIT, label, segment
    label = after
    segment += 1
    for i in range(n):
        y1[i] = x_land[i]
    code, _ = correct(y1, border, 0.0, unit_params, h, ws, y0, t0)
    if code != CORRECT_OK:
        return st.NOT_CONVERGED, label, segment
    margins(y0[:n], unit_params, g0)
    record_path(y0, segment, label, unit_params, h, gp, path, counts)
    return st.OK, label, segment
