"""What every time integrator shares: solver controls, dense output, events, recording.

An integrator hands each accepted step ``(t0, x0, ẋ0) → (t1, x1, ẋ1)`` to :func:`process_step`,
which

* fills the requested output samples inside the step by cubic Hermite interpolation of the
  positions (exact values and slopes at both ends: third order, the order of Rodas4's own dense
  output, and far below the local error of the explicit pair's tiny steps);
* detects each unit crossing its inversion threshold (``u - u_inversion`` changes sign between
  the step ends) and locates the crossing time on the interpolant by the Illinois method, so
  event times are not quantised to step ends. A unit that crosses twice within one step is not
  seen; steps are capped by ``CTRL_H_MAX`` for that reason;
* records per unit: first upward crossing (snap-through), last downward crossing (snap-back),
  last upward crossing and the number of crossings, and appends every crossing to a log.

Layouts
-------
``ctrl`` (float64, ``N_CTRL``): see the ``CTRL_*`` indices.
``unit_rec`` (float64, ``(N, N_REC)``): see the ``REC_*`` indices; times in s, NaN when absent.
``event_log`` (float64, ``(capacity, 3)``): time (s), unit index (0-based), direction (+1 up,
-1 down), in time order; crossings past the capacity are counted but not logged.
``stats`` (int64, ``N_STATS``): see the ``STAT_*`` indices.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..layout import COL_D, COL_P, COL_U_INV, free_node

# Solver controls.
CTRL_RTOL = 0
CTRL_ATOL = 1  # mm (positions); velocities are not in the error norm, see the integrators
CTRL_H_INIT = 2  # s; 0 picks one
CTRL_H_MAX = 3  # s
CTRL_MAX_STEPS = 4
CTRL_TAU_END = 5  # s; end of the pressure profile (last knot)
CTRL_STOP_WHEN_RESET = 6  # 1: stop once past TAU_END with every inverted unit reset
CTRL_H_MIN = 7  # s; a step below this fails the run
N_CTRL = 8

# Per-unit record.
REC_FIRST_UP = 0
REC_LAST_DOWN = 1
REC_LAST_UP = 2
REC_CROSSINGS = 3
REC_INVERTED = 4  # current state, 1.0 inverted
REC_EVER = 5  # 1.0 once the unit has been inverted (at the start or by a crossing)
N_REC = 6

# Statistics.
STAT_STEPS = 0
STAT_REJECTED = 1
STAT_RHS = 2
STAT_FACTOR = 3
STAT_EVENTS = 4
STAT_OUT = 5  # next output sample to fill
STAT_STOPPED_EARLY = 6
N_STATS = 7

_ILLINOIS_ITER = 80


@kernel
def hermite(theta, h, a0, s0, a1, s1):
    """Cubic Hermite interpolant at ``θ ∈ [0, 1]`` of values ``a0, a1`` and slopes ``s0, s1``."""
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = t3 - 2.0 * t2 + theta
    h01 = -2.0 * t3 + 3.0 * t2
    h11 = t3 - t2
    return h00 * a0 + h10 * h * s0 + h01 * a1 + h11 * h * s1


@kernel
def _interp_margin(k, theta, h, x0, xd0, x1, xd1, unit_params):
    """``u - u_inversion`` of unit ``k`` (1-based) on the step's Hermite interpolant."""
    a = 2 * k - 2
    b = 2 * k
    fb = free_node(b)
    bx = hermite(theta, h, x0[2 * fb], xd0[2 * fb], x1[2 * fb], xd1[2 * fb])
    by = hermite(theta, h, x0[2 * fb + 1], xd0[2 * fb + 1], x1[2 * fb + 1], xd1[2 * fb + 1])
    fa = free_node(a)
    if fa >= 0:
        ax = hermite(theta, h, x0[2 * fa], xd0[2 * fa], x1[2 * fa], xd1[2 * fa])
        ay = hermite(theta, h, x0[2 * fa + 1], xd0[2 * fa + 1], x1[2 * fa + 1], xd1[2 * fa + 1])
    else:
        ax = 0.0
        ay = 0.0
    row = unit_params[k - 1]
    ell = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2)
    return (ell - row[COL_P]) / row[COL_D] - row[COL_U_INV]


@kernel
def margins(x, unit_params, out):
    """Fill ``out`` with every unit's ``u - u_inversion`` at free coordinates ``x``."""
    n_units = unit_params.shape[0]
    for k in range(1, n_units + 1):
        fb = free_node(2 * k)
        bx = x[2 * fb]
        by = x[2 * fb + 1]
        fa = free_node(2 * k - 2)
        if fa >= 0:
            ax = x[2 * fa]
            ay = x[2 * fa + 1]
        else:
            ax = 0.0
            ay = 0.0
        row = unit_params[k - 1]
        ell = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2)
        out[k - 1] = (ell - row[COL_P]) / row[COL_D] - row[COL_U_INV]


@kernel
def init_record(x0, t0, unit_params, unit_rec, stats, g0):
    """Start a run: per-unit record from the initial positions, statistics zeroed."""
    margins(x0, unit_params, g0)
    for k in range(unit_params.shape[0]):
        unit_rec[k, REC_FIRST_UP] = np.nan
        unit_rec[k, REC_LAST_DOWN] = np.nan
        unit_rec[k, REC_LAST_UP] = np.nan
        unit_rec[k, REC_CROSSINGS] = 0.0
        inverted = 1.0 if g0[k] > 0.0 else 0.0
        unit_rec[k, REC_INVERTED] = inverted
        unit_rec[k, REC_EVER] = inverted
    for i in range(stats.shape[0]):
        stats[i] = 0


@kernel
def record_initial_samples(t0, x0, t_out, x_out, stats):
    """Store the output samples at (or before) the start time."""
    n = x0.shape[0]
    while stats[STAT_OUT] < t_out.shape[0] and t_out[stats[STAT_OUT]] <= t0:
        j = stats[STAT_OUT]
        for i in range(n):
            x_out[j, i] = x0[i]
        stats[STAT_OUT] += 1


@kernel
def _locate(k, step, unit_params, g_lo, g_hi):
    """Crossing ``θ`` of unit ``k`` inside the step (Illinois method on the interpolant)."""
    _, h, x0, xd0, x1, xd1 = step
    lo = 0.0
    hi = 1.0
    f_lo = g_lo
    f_hi = g_hi
    side = 0
    theta = 1.0
    for _ in range(_ILLINOIS_ITER):
        theta = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        if not (lo < theta < hi):
            theta = 0.5 * (lo + hi)
        f = _interp_margin(k, theta, h, x0, xd0, x1, xd1, unit_params)
        if f == 0.0:
            return theta
        if (f > 0.0) == (f_hi > 0.0):
            hi = theta
            f_hi = f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo = theta
            f_lo = f
            if side == -1:
                f_hi *= 0.5
            side = -1
        if (hi - lo) * h < 1e-13 * max(1.0, abs(h)):
            break
    return theta


@kernel
def process_step(step, g0, g1, unit_params, record):
    """Outputs and events of one accepted step; ``g0`` must hold the margins at ``x0``.

    ``step`` is the :class:`~.records.AcceptedStep`, ``record`` the run's
    :class:`~.records.RunRecord` (samples, per-unit record, event log, counters). On return
    ``g0`` holds the margins at ``x1`` (``g1`` is scratch).
    """
    t0, h, x0, xd0, x1, xd1 = step
    t_out, x_out, unit_rec, event_log, stats = record
    n = x0.shape[0]
    t1 = t0 + h
    n_out = t_out.shape[0]
    while stats[STAT_OUT] < n_out and t_out[stats[STAT_OUT]] <= t1:
        j = stats[STAT_OUT]
        theta = (t_out[j] - t0) / h
        for i in range(n):
            x_out[j, i] = hermite(theta, h, x0[i], xd0[i], x1[i], xd1[i])
        stats[STAT_OUT] += 1
    margins(x1, unit_params, g1)
    n_units = unit_params.shape[0]
    # Crossings of this step, time-ordered before logging (usually zero or one).
    first = stats[STAT_EVENTS]
    for k in range(n_units):
        was = unit_rec[k, REC_INVERTED] > 0.0
        now = g1[k] > 0.0
        if was == now:
            continue
        theta = _locate(k + 1, step, unit_params, g0[k], g1[k])
        t_cross = t0 + theta * h
        unit_rec[k, REC_CROSSINGS] += 1.0
        if now:
            if unit_rec[k, REC_FIRST_UP] != unit_rec[k, REC_FIRST_UP]:
                unit_rec[k, REC_FIRST_UP] = t_cross
            unit_rec[k, REC_LAST_UP] = t_cross
            unit_rec[k, REC_EVER] = 1.0
            unit_rec[k, REC_INVERTED] = 1.0
        else:
            unit_rec[k, REC_LAST_DOWN] = t_cross
            unit_rec[k, REC_INVERTED] = 0.0
        slot = stats[STAT_EVENTS]
        if slot < event_log.shape[0]:
            # insertion into the time-ordered tail of this step's events
            j = slot
            while j > first and event_log[j - 1, 0] > t_cross:
                event_log[j, 0] = event_log[j - 1, 0]
                event_log[j, 1] = event_log[j - 1, 1]
                event_log[j, 2] = event_log[j - 1, 2]
                j -= 1
            event_log[j, 0] = t_cross
            event_log[j, 1] = k
            event_log[j, 2] = 1.0 if now else -1.0
        stats[STAT_EVENTS] += 1
    for k in range(n_units):
        g0[k] = g1[k]


#: Time without a threshold crossing (s) before a run whose inverted units are all back below
#: their thresholds may stop. A neighbour's snap can push a dome that has just crossed its
#: threshold back over it (a crossing inside the ghost of a metastable dome's fold is not yet a
#: snap), so the first moment every unit is down is not proof that the last crossing happened.
SETTLE_TIME = 1.0


@kernel
def all_reset(unit_rec):
    """True when every unit that was ever inverted is back below its threshold."""
    for k in range(unit_rec.shape[0]):
        if unit_rec[k, REC_EVER] > 0.0 and unit_rec[k, REC_INVERTED] > 0.0:
            return False
    return True


@kernel
def last_crossing(unit_rec, since):
    """Latest threshold crossing of any unit, or ``since`` if none is later (s)."""
    latest = since
    for k in range(unit_rec.shape[0]):
        for col in (REC_LAST_DOWN, REC_LAST_UP):
            t_cross = unit_rec[k, col]
            if t_cross == t_cross and t_cross > latest:
                latest = t_cross
    return latest


@kernel
def settled_reset(unit_rec, t, tau_end):
    """True when every inverted unit has reset and nothing has crossed for :data:`SETTLE_TIME`.

    The quiet time counts from the later of the last crossing and ``tau_end`` (the end of the
    pressure profile, s); a run may stop early only when this holds.
    """
    return all_reset(unit_rec) and t - last_crossing(unit_rec, tau_end) >= SETTLE_TIME


@kernel
def next_knot(t, knot_t, t_end):
    """The first knot strictly after ``t`` (or ``t_end``): steps never cross a kink of P(t)."""
    for i in range(knot_t.shape[0]):
        if knot_t[i] > t and knot_t[i] < t_end:
            return knot_t[i]
    return t_end


@kernel
def clip_to_knot(t, step, knot_t, t_end):
    """Step from ``t`` shortened to land on the next knot (or ``t_end``) if it would reach it.

    Returns ``(step, t_stop, lands)``: ``lands`` says the step ends exactly at ``t_stop``
    (the integrators then set ``t = t_stop`` instead of ``t + step``, free of round-off).
    """
    t_stop = next_knot(t, knot_t, t_end)
    if t + step >= t_stop - 1e-12 * max(1.0, abs(t_stop)):
        return t_stop - t, t_stop, True
    return step, t_stop, False


@kernel
def pressure_slope(t_mid, knot_t, knot_p):
    """dP/dt (MPa/s) of the profile segment containing ``t_mid``."""
    n = knot_t.shape[0]
    for i in range(1, n):
        if knot_t[i - 1] <= t_mid < knot_t[i]:
            dt = knot_t[i] - knot_t[i - 1]
            if dt > 0.0:
                return (knot_p[i] - knot_p[i - 1]) / dt
            return 0.0
    return 0.0


@kernel
def error_norm(err, y0, y1, n, rtol, atol):
    """RMS of ``err / (atol + rtol max(|y0|, |y1|))`` over the first ``n`` components."""
    s = 0.0
    for i in range(n):
        sc = atol + rtol * max(abs(y0[i]), abs(y1[i]))
        r = err[i] / sc
        s += r * r
    return math.sqrt(s / n)
