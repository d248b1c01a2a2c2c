"""The physical core of the fast reset-time model: static loading, then the release only.

Per design (:func:`fast_reset_design`): the loaded equilibrium after a long hold and the
pattern of snapped domes (:func:`.reset.loaded_state.loaded_state`, no loading dynamics), then the
release ramp and the creep after it (:func:`.reset.release.release_rodas3`, overdamped, loose
tolerance, stopping as soon as no further crossing can happen). The per-unit summary is the
one the full model uses (:func:`.dynamics.batch.summarise_units`), so reset time, class and
final state mean the same; snap-through times are not computed (NaN). Diagnostics per design
and per unit feed the fitted correction and interval of
:mod:`dpfexplore.solvers.dynamics.fast_reset`.

Assumptions (the fitted interval measures what they cost): a single pulse whose hold is long
against the finger's slowest relaxation (the finger is in its loaded equilibrium when the
release starts), quasi-static loading (which domes snap is decided by the static test of
:mod:`.reset.loaded_state`), and the overdamped model.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ...model import status as st
from .._jit import batch_kernel, kernel
from ..dynamics.batch import summarise_units
from ..dynamics.events import (
    N_REC,
    N_STATS,
    REC_CROSSINGS,
    STAT_REJECTED,
    STAT_STEPS,
    STAT_STOPPED_EARLY,
)
from ..dynamics.motion import N_PHYS, PHYS_ETA, PHYS_ETA_ISO
from ..layout import n_free
from ..records import FastResetUnits, Lattice, MotionModel, ReleaseRecord
from ..statics.newton import workspace
from .loaded_state import loaded_state
from .release import N_RELEASE_DIAG, release_rodas3, release_workspace

# Per-design diagnostics (``design_diag`` columns).
DD_LOAD_STATUS = 0
DD_LOAD_ITER = 1  # Newton iterations of the loading
DD_LOAD_MARGIN = 2  # N, smallest |λ| of the snap decisions (how close a dome was to the other side)
DD_STEPS = 3
DD_REJECTED = 4
DD_CHECK_ITER = 5  # Newton iterations of the static checks
DD_STOP = 6  # release.STOP_*
DD_T_STOP = 7  # s after the end of the profile
N_DESIGN_DIAG = 8

# Per-unit diagnostics (``unit_diag`` columns); the release writes its own block at the end.
UD_U_LOAD = 0  # dome extension x̄/d at the loaded equilibrium
UD_MARGIN = 1  # N, the snap decision's λ (negative: snapped)
UD_CROSSINGS = 2  # threshold crossings during the release
UD_RELEASE = 3  # first column of the release's N_RELEASE_DIAG columns
N_UNIT_DIAG = UD_RELEASE + N_RELEASE_DIAG


@kernel(inline="always")
def fast_reset_design(lattice, knots, physics, ctrl, t_end, out, newton_ws):
    """Reset times of one design under a single pulse; returns ``(status, final_state)``.

    Parameters
    ----------
    lattice : Lattice
        ``unit_params`` of shape (N, N_COLS) and ``h`` (mm) (:mod:`.records`).
    knots : PressureKnots
        The pulse ``(τ1..τ4)``, ``(0, P0, P0, 0)``; the release starts at ``τ3``.
    physics : Physics
        Damping ``eta``, ``eta_iso`` (N·s/mm); the model is overdamped (no mass read).
    ctrl : ndarray of shape (N_CTRL,)
        Release controls (:mod:`.dynamics.events` layout).
    t_end : float, s
    out : FastResetUnits
        ``reset``, ``snap_back`` (N,), s, as in ``reset_times_batch`` (reset after ``τ4``;
        inf / NaN); ``unit_class`` (int8, (N,)); ``unit_diag`` (N, N_UNIT_DIAG);
        ``design_diag`` (N_DESIGN_DIAG,).
    newton_ws : tuple
        :func:`.statics.newton.workspace`.

    Compiled inline into :func:`fast_reset_batch` (no machine code of its own).
    """
    # attribute reads, not unpacking: compiled inline into the batch's prange body, unpacking a
    # record built there trips Numba's array analysis (docs/decisions.md, "Less to compile")
    unit_params = lattice.unit_params
    h = lattice.h
    knot_t = knots.t
    knot_p = knots.p
    reset = out.reset
    snap_back = out.snap_back
    unit_class = out.unit_class
    unit_diag = out.unit_diag
    design_diag = out.design_diag
    n_units = unit_params.shape[0]
    x = np.empty(n_free(n_units))
    margin = np.empty(n_units)
    u = np.empty(n_units)
    code, _, n_iter = loaded_state(unit_params, h, knot_p[1], x, margin, u)
    design_diag[DD_LOAD_STATUS] = code
    design_diag[DD_LOAD_ITER] = n_iter
    if code != st.OK:
        return code, -1
    smallest = np.inf
    for k in range(n_units):
        unit_diag[k, UD_U_LOAD] = u[k]
        unit_diag[k, UD_MARGIN] = margin[k]
        smallest = min(smallest, abs(margin[k]))
    design_diag[DD_LOAD_MARGIN] = smallest
    rec = np.empty((n_units, N_REC))
    stats = np.zeros(N_STATS, dtype=np.int64)
    counters = np.zeros(2, dtype=np.int64)
    phys = np.zeros(N_PHYS)
    phys[PHYS_ETA] = physics.eta
    phys[PHYS_ETA_ISO] = physics.eta_iso
    code = release_rodas3(
        x,
        MotionModel(unit_params, h, knot_t, knot_p, phys),
        ctrl,
        knot_t[2],
        t_end,
        ReleaseRecord(rec, stats, unit_diag[:, UD_RELEASE:], counters),
        release_workspace(n_units),
        newton_ws,
    )
    design_diag[DD_STEPS] = stats[STAT_STEPS]
    design_diag[DD_REJECTED] = stats[STAT_REJECTED]
    design_diag[DD_CHECK_ITER] = counters[0]
    design_diag[DD_STOP] = stats[STAT_STOPPED_EARLY]
    tau_end = knot_t[knot_t.shape[0] - 1]
    snap_through = np.empty(n_units)
    classes = np.empty(n_units, dtype=np.int64)
    state = summarise_units(rec, tau_end, code, reset, snap_through, snap_back, classes)
    for k in range(n_units):
        unit_class[k] = classes[k]
        unit_diag[k, UD_CROSSINGS] = rec[k, REC_CROSSINGS]
    return code, state


@batch_kernel
def fast_reset_batch(lattice, valid, knots, physics, ctrl, t_end, out):
    """:func:`fast_reset_design` over the valid rows of a batch in parallel (``prange``).

    ``lattice`` a :class:`~.records.LatticeBatch`, ``out`` :class:`~.records.FastResetRows`:
    arrays ``(n,)``, ``(n, MAX_UNITS)``, ``(n, MAX_UNITS, N_UNIT_DIAG)`` and
    ``(n, N_DESIGN_DIAG)``; invalid rows and the padding beyond each ``N`` are left untouched.
    """
    unit_params, h, n_units = lattice
    status, final_state, reset, snap_back, unit_class, unit_diag, design_diag = out
    for i in prange(unit_params.shape[0]):
        if not valid[i]:
            continue
        nu = n_units[i]
        code, state = fast_reset_design(
            Lattice(unit_params[i, :nu], h[i]),
            knots,
            physics,
            ctrl,
            t_end,
            FastResetUnits(
                reset[i, :nu],
                snap_back[i, :nu],
                unit_class[i, :nu],
                unit_diag[i, :nu],
                design_diag[i],
            ),
            workspace(),
        )
        status[i] = code
        final_state[i] = state
