"""One simulation from rest, its per-unit summary, and the ``prange`` batch over designs.

The per-unit summary (reset time, class, final state) is defined once here and used by both
:func:`dpfexplore.solvers.dynamics.simulate.simulate` and the batch, so a single design and a sweep
row cannot disagree.

Reset time (MODEL.md §8)
    Time of the unit's last downward crossing of its threshold minus ``τ_end`` (the last knot
    of the pressure profile). ``inf`` if the unit is still inverted at the end of the run (the
    horizon is reported with it); NaN if it never inverted. It is negative when the unit was
    already back before the profile ended (a monostable dome resetting during the release
    ramp): that is information, not an error, so it is kept.
Class within the finger
    bistable (still inverted at the end), metastable (reset time ≥ 0.05 s), monostable (reset
    sooner, including during the release ramp), or -1 (never inverted). A metastable unit
    whose reset takes longer than the horizon is reported bistable: the horizon bounds what a
    simulation can tell.
No contact
    A unit whose reach ``d`` was clamped (MODEL.md §3: the closed form gave ``d <= 0``) has no
    inversion in this model's sense: its threshold sits a few µm from flat. Its class is set to
    ``CLASS_NO_CONTACT`` after the run, outside the kernels
    (:func:`dpfexplore.solvers.dynamics.common.mark_no_contact`), which only know ``d``.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ...model import status as st
from .._jit import batch_kernel, kernel
from ..lattice import pack_free, rest_nodes
from ..layout import n_free, n_nodes
from ..records import MotionModel, RunRecord
from .events import (
    N_REC,
    N_STATS,
    REC_EVER,
    REC_FIRST_UP,
    REC_INVERTED,
    REC_LAST_DOWN,
)
from .explicit import dopri5
from .ids import INTEGRATOR_DOPRI5, INTEGRATOR_RODAS4
from .motion import N_PHYS, PHYS_MASS
from .rosenbrock import rodas4

#: Shortest reset time (s) of a metastable unit; quicker ones are monostable (MODEL.md §8).
METASTABLE_MIN_RESET = 0.05

CLASS_NEVER_INVERTED = -1
CLASS_BISTABLE = 0
CLASS_METASTABLE = 1
CLASS_MONOSTABLE = 2
CLASS_NO_CONTACT = 3


@kernel
def rest_state(unit_params, h, y):
    """Fill ``y = [x, v]`` with the flat stress-free finger at rest."""
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    pos = np.empty((n_nodes(n_units), 2))
    rest_nodes(unit_params, h, pos)
    pack_free(pos, n_units, y[:n])
    for i in range(n, 2 * n):
        y[i] = 0.0


#: The integrator kernel of each id (:mod:`.dynamics.ids`), each ``(y, t0, t_end, model, ctrl,
#: record)``: a caller picks one outside the kernels, so only the integrator it runs is compiled.
INTEGRATORS = {INTEGRATOR_RODAS4: rodas4, INTEGRATOR_DOPRI5: dopri5}


@kernel
def summarise_units(unit_rec, tau_end, status, reset, snap_through, snap_back, unit_class):
    """Per-unit reset time, snap times and class from a run's record; returns the final state.

    The final state is an integer with unit 1 as the most significant bit. When the run did
    not finish (``status != OK``), units still inverted get NaN reset times and class -1: the
    run cannot say whether they would have reset.
    """
    n_units = unit_rec.shape[0]
    state = 0
    for k in range(n_units):
        inverted = unit_rec[k, REC_INVERTED] > 0.0
        state = 2 * state + (1 if inverted else 0)
        snap_through[k] = unit_rec[k, REC_FIRST_UP]
        snap_back[k] = unit_rec[k, REC_LAST_DOWN]
        if unit_rec[k, REC_EVER] == 0.0:
            reset[k] = np.nan
            unit_class[k] = CLASS_NEVER_INVERTED
        elif inverted:
            if status == st.OK:
                reset[k] = np.inf
                unit_class[k] = CLASS_BISTABLE
            else:
                reset[k] = np.nan
                unit_class[k] = CLASS_NEVER_INVERTED
        else:
            r = unit_rec[k, REC_LAST_DOWN] - tau_end
            reset[k] = r
            unit_class[k] = CLASS_METASTABLE if r >= METASTABLE_MIN_RESET else CLASS_MONOSTABLE
    return state


@kernel
def start_run(unit_params, h, physics):
    """One design's start from rest: its state ``y = [x, v]``, physics and empty run record.

    Parameters
    ----------
    unit_params : ndarray of shape (N, N_UNIT)
    h : float, mm
    physics : Physics
        Damping (N·s/mm) and mass per unit (tonne; 0: the overdamped model).

    Returns
    -------
    y : ndarray of shape (2 (4N - 2),)
    phys : ndarray of shape (N_PHYS,)
        ``eta``, ``eta_iso`` and the node mass of this design.
    run : RunRecord
        No samples, no event log; the per-unit record and the step statistics to fill.
    """
    nu = unit_params.shape[0]
    nf = n_free(nu)
    y = np.empty(2 * nf)
    rest_state(unit_params, h, y)
    phys = np.empty(N_PHYS)
    phys[0] = physics.eta
    phys[1] = physics.eta_iso
    phys[PHYS_MASS] = physics.mass_per_unit * nu / (2.0 * nu + 2.0)
    run = RunRecord(
        np.empty(0),
        np.empty((0, nf)),
        np.empty((nu, N_REC)),
        np.empty((0, 3)),
        np.zeros(N_STATS, dtype=np.int64),
    )
    return y, phys, run


@kernel
def finish_row(i, code, unit_rec, tau_end, out):
    """Write row ``i`` of ``out`` (ResetRows) from a run's status ``code`` and unit record."""
    nu = unit_rec.shape[0]
    out.status[i] = code
    cls = np.empty(nu, dtype=np.int64)
    out.final_state[i] = summarise_units(
        unit_rec,
        tau_end,
        code,
        out.reset[i, :nu],
        out.snap_through[i, :nu],
        out.snap_back[i, :nu],
        cls,
    )
    for k in range(nu):
        out.unit_class[i, k] = cls[k]


@batch_kernel
def reset_times_rodas4(lattice, valid, knots, physics, ctrl, t_end, out):
    """Simulate every valid design from rest under one profile with Rodas4, in parallel.

    Parameters
    ----------
    lattice : LatticeBatch
        The padded batch tables (:mod:`.records`).
    valid : ndarray of bool, shape (n,)
        Rows to run; invalid rows are left untouched.
    knots : PressureKnots
        The pressure profile.
    physics : Physics
        Damping and mass per unit (0: the overdamped model).
    ctrl : ndarray of shape (N_CTRL,)
        Integrator controls (:mod:`.dynamics.events` layout).
    t_end : float, s
    out : ResetRows
        Arrays of shape ``(n,)`` or ``(n, MAX_UNITS)``; the padding beyond a design's ``N`` is
        left untouched.
    """
    n = lattice.unit_params.shape[0]
    tau_end = knots.t[knots.t.shape[0] - 1]
    for i in prange(n):
        if valid[i]:
            params = lattice.unit_params[i, : lattice.n_units[i]]
            y, phys, run = start_run(params, lattice.h[i], physics)
            model = MotionModel(params, lattice.h[i], knots.t, knots.p, phys)
            code = rodas4(y, 0.0, t_end, model, ctrl, run)
            finish_row(i, code, run.unit_rec, tau_end, out)


@batch_kernel
def reset_times_dopri5(lattice, valid, knots, physics, ctrl, t_end, out):
    """:func:`reset_times_rodas4` with the explicit Dormand-Prince integrator (same arguments)."""
    n = lattice.unit_params.shape[0]
    tau_end = knots.t[knots.t.shape[0] - 1]
    for i in prange(n):
        if valid[i]:
            params = lattice.unit_params[i, : lattice.n_units[i]]
            y, phys, run = start_run(params, lattice.h[i], physics)
            model = MotionModel(params, lattice.h[i], knots.t, knots.p, phys)
            code = dopri5(y, 0.0, t_end, model, ctrl, run)
            finish_row(i, code, run.unit_rec, tau_end, out)


#: The batch kernel of each integrator id: ``(lattice, valid, knots, physics, ctrl, t_end, out)``.
#: Two module-level kernels, not closures over the integrator: Numba keys a closure's cache
#: entries by its pickled free variables, and a pickled dispatcher differs in every process.
RESET_TIMES_KERNELS = {
    INTEGRATOR_RODAS4: reset_times_rodas4,
    INTEGRATOR_DOPRI5: reset_times_dopri5,
}
