"""The release model: a loose loading, a Newton jump to the end of the hold, the release.

Reset times depend on the loading through the state at the start of the release. Two things
make the full run expensive and neither needs full accuracy for that state: the snap-through
cascade during loading (about half the steps), whose outcome is an inversion pattern, and the
slow settling during the hold, whose end is the loaded equilibrium
``F_ext(x, P0) - ∇E(x) = 0``. The release model integrates the loading (overdamped Rodas4) at
a loose tolerance (:data:`LOADING_ATOL`), replaces the state at ``τ3`` by the loaded
equilibrium reached by Newton from it (so the pattern is the dynamics', the settling exact),
and integrates the release at the requested tolerance.

Assumptions, and what breaks them (the error is measured by ``dpfexplore bench dynamics``):
the hold lasts several of the slowest relaxation times (1.2 /s for the pick-and-place finger;
a shorter hold leaves the finger short of equilibrium, up to ~1 % in reset time, see the
hold-time map); a unit whose snap-through is decided within the loose tolerance may be
misclassified; the profile is a single pulse.

Newton on the non-symmetric system is :func:`.reset.loaded_state.loaded_newton`: the Jacobian
``P_J - H`` of :func:`.dynamics.motion.stiffness_jacobian` (at zero velocity) and the banded LU,
with Armijo backtracking on ``½|R|²`` and the step capped so no coordinate moves more than
``max_move`` mm per iteration. Converged when the largest residual force is below ``ftol`` N or
the Newton step below 1e-11 mm.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ...model import status as st
from .._jit import batch_kernel, kernel
from ..dynamics.batch import rest_state, summarise_units
from ..dynamics.events import (
    CTRL_ATOL,
    CTRL_STOP_WHEN_RESET,
    N_REC,
    N_STATS,
    REC_EVER,
    REC_FIRST_UP,
    REC_LAST_DOWN,
    STAT_STEPS,
)
from ..dynamics.motion import N_PHYS
from ..dynamics.rosenbrock import rodas4
from ..layout import n_free
from ..records import Lattice, MotionModel, RunRecord
from .loaded_state import loaded_newton, newton_scratch

#: Position tolerance (mm) of the loading phase: loose, because only the inversion pattern and
#: the snap-through times (to ~1e-3 s) are taken from it; the Newton solve fixes the state.
LOADING_ATOL = 1e-2
#: Newton iteration cap of the equilibrium at the end of the hold (int64, not a literal: see
#: the package docstring).
HOLD_MAX_ITER = np.int64(50)


@kernel
def loaded_equilibrium(x, unit_params, h, pressure, ftol, max_iter, max_move):
    """Solve ``F_ext(x, P) = ∇E(x)`` in place from ``x`` by damped Newton; returns a status.

    :func:`.reset.loaded_state.loaded_newton` with its own scratch (see the module docstring).
    """
    code, _ = loaded_newton(
        x, unit_params, h, pressure, ftol, max_iter, max_move, newton_scratch(unit_params.shape[0])
    )
    return code


@kernel(inline="always")
def release_run(lattice, knots, physics, ctrl, t_end, rec, stats, y):
    """Loose loading, the loaded equilibrium at ``τ3`` by Newton, then the release.

    ``knot_t`` must be a single pulse ``(τ1, τ2, τ3, τ4)``. ``y`` (shape ``(2 (4N - 2),)``)
    receives the final state; ``rec`` the per-unit record of both phases (snap-through times
    from the loose loading), or of the loading alone when it or the loaded equilibrium fails.
    ``lattice``, ``knots``, ``physics``: :mod:`.records` (the model is overdamped:
    ``physics.mass_per_unit`` is not read). Returns a status. Compiled inline into
    :func:`release_batch` (no machine code of its own).
    """
    # attribute reads, not unpacking: compiled inline into the batch's prange body, unpacking a
    # record built there trips Numba's array analysis (docs/decisions.md, "Less to compile")
    unit_params = lattice.unit_params
    h = lattice.h
    knot_t = knots.t
    knot_p = knots.p
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    rest_state(unit_params, h, y)
    phys = np.empty(N_PHYS)
    phys[0] = physics.eta
    phys[1] = physics.eta_iso
    phys[2] = 0.0
    t_out = np.empty(0)
    x_out = np.empty((0, n))
    log = np.empty((0, 3))
    tau3 = knot_t[2]
    loose = ctrl.copy()
    loose[CTRL_ATOL] = max(ctrl[CTRL_ATOL], LOADING_ATOL)
    loose[CTRL_STOP_WHEN_RESET] = 0.0
    loading = np.empty((n_units, N_REC))
    model = MotionModel(unit_params, h, knot_t, knot_p, phys)
    code = rodas4(y, 0.0, tau3, model, loose, RunRecord(t_out, x_out, loading, log, stats))
    if code != st.OK:
        rec[:, :] = loading  # the run's record ends with the loading
        return code
    steps = stats[STAT_STEPS]
    # The state at the end of a long hold: the loaded equilibrium, polished from where the
    # loose loading left the finger (so its inversion pattern is the dynamics').
    code = loaded_equilibrium(y[:n], unit_params, h, knot_p[2], 1e-9, HOLD_MAX_ITER, 0.5)
    if code != st.OK:
        rec[:, :] = loading  # the run's record ends with the loading
        return code
    code = rodas4(y, tau3, t_end, model, ctrl, RunRecord(t_out, x_out, rec, log, stats))
    stats[STAT_STEPS] += steps
    for k in range(n_units):
        # carry over what happened during the loading
        rec[k, REC_FIRST_UP] = loading[k, REC_FIRST_UP]
        if loading[k, REC_EVER] > 0.0:
            rec[k, REC_EVER] = 1.0
            if rec[k, REC_LAST_DOWN] != rec[k, REC_LAST_DOWN]:
                rec[k, REC_LAST_DOWN] = loading[k, REC_LAST_DOWN]
    return code


@batch_kernel
def release_batch(lattice, valid, knots, physics, ctrl, t_end, out):
    """:func:`release_run` over many designs in parallel (arguments as a reset-times batch's)."""
    unit_params, h, n_units = lattice
    status, final_state, reset, snap_through, snap_back, unit_class = out
    n = unit_params.shape[0]
    knot_t = knots.t
    tau_end = knot_t[knot_t.shape[0] - 1]
    for i in prange(n):
        if not valid[i]:
            continue
        nu = n_units[i]
        params = unit_params[i, :nu]
        y = np.empty(2 * n_free(nu))
        rec = np.empty((nu, N_REC))
        stats = np.zeros(N_STATS, dtype=np.int64)
        code = release_run(Lattice(params, h[i]), knots, physics, ctrl, t_end, rec, stats, y)
        status[i] = code
        if code != st.OK and stats[STAT_STEPS] == 0:
            continue  # failed before any step: nothing to summarise
        cls = np.empty(nu, dtype=np.int64)
        final_state[i] = summarise_units(
            rec, tau_end, code, reset[i, :nu], snap_through[i, :nu], snap_back[i, :nu], cls
        )
        for k in range(nu):
            unit_class[i, k] = cls[k]
