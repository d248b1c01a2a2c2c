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


def _reset_times_kernel(integrate):
    """The ``prange`` batch over designs of the integrator kernel ``integrate`` (INTEGRATORS).

    ``integrate`` is the closure's free variable: each integrator has a batch kernel of its own
    (Numba keys a closure's cache entries by its free variables), so a batch compiles only the
    integrator it runs.
    """

    @batch_kernel
    def batch(lattice, valid, knots, physics, ctrl, t_end, out):
        """Simulate every valid design from rest under one profile, in parallel (``prange``).

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
        unit_params, h, n_units = lattice
        knot_t, knot_p = knots
        eta, eta_iso, mass_per_unit = physics
        status, final_state, reset, snap_through, snap_back, unit_class = out
        n = unit_params.shape[0]
        tau_end = knot_t[knot_t.shape[0] - 1]
        for i in prange(n):
            if not valid[i]:
                continue
            nu = n_units[i]
            params = unit_params[i, :nu]
            nf = n_free(nu)
            y = np.empty(2 * nf)
            rest_state(params, h[i], y)
            phys = np.empty(N_PHYS)
            phys[0] = eta
            phys[1] = eta_iso
            phys[PHYS_MASS] = mass_per_unit * nu / (2.0 * nu + 2.0)
            rec = np.empty((nu, N_REC))
            log = np.empty((0, 3))
            stats = np.zeros(N_STATS, dtype=np.int64)
            t_out = np.empty(0)
            x_out = np.empty((0, nf))
            code = integrate(
                y,
                0.0,
                t_end,
                MotionModel(params, h[i], knot_t, knot_p, phys),
                ctrl,
                RunRecord(t_out, x_out, rec, log, stats),
            )
            status[i] = code
            cls = np.empty(nu, dtype=np.int64)
            final_state[i] = summarise_units(
                rec, tau_end, code, reset[i, :nu], snap_through[i, :nu], snap_back[i, :nu], cls
            )
            for k in range(nu):
                unit_class[i, k] = cls[k]

    return batch


#: The batch kernel of each integrator id: ``(lattice, valid, knots, physics, ctrl, t_end, out)``.
RESET_TIMES_KERNELS = {key: _reset_times_kernel(value) for key, value in INTEGRATORS.items()}
