"""Where a finger comes to rest after it snaps at a fold: the landing, decided by the dynamics.

Past a fold of its equilibrium branch (:mod:`.snap.continuation`) the finger has nowhere nearby to
stay and moves. Where it lands is not a property of the static branch: it depends on how the
motion carries it (which units a cascade takes along), so :func:`land` simulates it. The fold
state is kicked along the branch's direction of travel (the fold's null direction, toward the
unstable branch: the side a slow ramp pushes it; :func:`default_kick`), and the equations of
motion of MODEL.md §8 (Rodas4, full or overdamped) run at the fold pressure plus a small offset
until the motion has settled near an equilibrium that Newton polishes at the fold pressure and
:func:`certify_stable` certifies. The load is not conservative, so "stable" means that every
mode of the linearised motion decays.
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from .._jit import kernel
from ..dynamics.events import CTRL_H_INIT, N_REC, N_STATS, STAT_STEPS, margins
from ..dynamics.motion import PHYS_ETA, PHYS_ETA_ISO, damping_matrix
from ..dynamics.rosenbrock import rodas4
from ..layout import n_free
from ..linalg.banded_lu import LATTICE_HALF_BANDWIDTH as BAND
from ..linalg.banded_lu import lu_factor, lu_solve
from ..linalg.cholesky import cholesky
from ..records import MotionModel, RunRecord
from ..reset.reduced import loaded_equilibrium
from .continuation import WITH_JACOBIAN, residual, workspace

#: Default kick (mm, largest coordinate) along the fold's null direction before the motion
#: starts, and the most it may change any dome's extension, in reaches (:func:`default_kick`).
#: A kick is a shortcut through the slow passage past the fold, small enough to keep the
#: motion on the fold's unstable manifold: on 99 snaps of 25 random designs (paper box,
#: N = 2-5) kicks of 0.01 and 0.03 mm landed where a 0.003 mm kick integrated at atol 1e-6 mm
#: did; a plain 0.1 mm kick changed 11 of those landings, all of units without dome contact,
#: whose reach is 0.01 mm (the kick moved them by ten reaches): hence the second limit.
LANDING_KICK = 0.1
KICK_DU = 1.0
#: The motion runs at the fold pressure plus the first of these (MPa, in the ramp's direction):
#: past the fold there is no equilibrium nearby, so the kicked state cannot creep back. Where
#: the fold is so flat that the motion has not settled after MAX_SETTLE s (the passage time
#: grows as the inverse square root of the offset), the next offset takes over. The landing is
#: polished at the fold pressure either way; the offset used is returned.
LANDING_DP = (1e-8, 1e-5, 1e-3)
#: First stretch of simulated motion (s); each further stretch doubles, up to MAX_SETTLE per
#: offset.
FIRST_CHUNK = 0.05
MAX_SETTLE = 400.0
#: The relaxed state is accepted when Newton (at the fold pressure) moves it by at most
#: POLISH_MAX mm onto an equilibrium certified stable and at least JUMP_MIN kicks away from the
#: fold (not Newton's way back onto the fold, whose Jacobian is singular). Accepting at 0.05,
#: 0.2 or 0.5 mm gave the same landings on 69 snaps of random designs (N = 4 and 8), each
#: within 1e-6 mm of a landing integrated at atol 1e-5 mm and polished from 0.01 mm.
POLISH_MAX = 0.2
JUMP_MIN = 0.1
#: Newton polish: residual tolerance (N), iterations (near an equilibrium it converges in a
#: few; mid-snap it should give up early), largest move per iteration (mm).
POLISH_FTOL = 1e-9
POLISH_ITER = np.int64(10)  # int64, not a literal: see the package docstring
POLISH_MOVE = 0.5
#: Stability margin required of the eigenvalue certificate, relative to the largest rate.
STABLE_RTOL = 1e-10
#: Entries of a landing's ``info`` array (:func:`land`): the stability certificate, seconds of
#: motion simulated, Rodas4 steps, the kick used (mm) and the pressure offset (MPa).
LAND_CERT = 0
LAND_SECONDS = 1
LAND_STEPS = 2
LAND_KICK = 3
LAND_OFFSET = 4
N_LAND_INFO = 5


@kernel
def default_kick(x_fold, direction, unit_params):
    """Kick (mm) along ``direction`` (largest coordinate 1) from the fold ``x_fold``.

    ``LANDING_KICK``, or less if that would change a dome's extension ``u`` by more than
    ``KICK_DU`` (a unit without dome contact has a reach of 0.01 mm).
    """
    n_units = unit_params.shape[0]
    n = x_fold.shape[0]
    probe = 1e-6
    trial = np.empty(n)
    g_plus = np.empty(n_units)
    g_minus = np.empty(n_units)
    for i in range(n):
        trial[i] = x_fold[i] + probe * direction[i]
    margins(trial, unit_params, g_plus)
    for i in range(n):
        trial[i] = x_fold[i] - probe * direction[i]
    margins(trial, unit_params, g_minus)
    kick = LANDING_KICK
    for k in range(n_units):
        slope = abs(g_plus[k] - g_minus[k]) / (2.0 * probe)  # reaches per mm of kick
        if slope * kick > KICK_DU:
            kick = KICK_DU / slope
    return kick


@kernel
def certify_stable(x, pressure, unit_params, h, eta, eta_iso):
    """Certify that the equilibrium ``x`` at ``pressure`` is linearly stable.

    First test: the symmetric part of ``K = H - P J_p`` is positive definite (block Cholesky).
    With a symmetric positive definite damping matrix ``C`` every eigenvalue ``λ`` of the
    overdamped linearisation ``C v̇ = -K v`` then has ``Re λ > 0`` (``λ v*Cv = v*Kv``, whose
    real part is ``v* sym(K) v``), and the inertia of MODEL.md §8 is too small to change that
    (its own modes relax in ~1e-5 s). Otherwise the eigenvalues of ``C⁻¹K`` decide (LAPACK).

    Returns
    -------
    float
        ``inf`` when the symmetric part is positive definite; else the smallest real part of
        the eigenvalues of ``C⁻¹K`` (1/s), positive when stable (``<= 0``: not certified;
        NaN if the matrices are not finite).
    """
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    ws = workspace(n_units)
    pos, _, _, jac, _, _, _, _, _ = ws
    if not math.isfinite(residual(x, pressure, unit_params, h, ws, WITH_JACOBIAN)):
        return np.nan
    sym = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            sym[i, j] = 0.5 * (jac[i, j] + jac[j, i])
    low = np.empty((n, n))
    if cholesky(sym, 0.0, low, n):
        return np.inf
    cmat = np.empty((n, n))
    damping_matrix(pos, unit_params, h, eta, eta_iso, np.empty(n), cmat)
    piv = np.empty(n, dtype=np.int64)
    if lu_factor(cmat, n, piv, BAND) != 0:
        return np.nan
    rates = np.empty((n, n), dtype=np.complex128)
    col = np.empty(n)
    for j in range(n):
        for i in range(n):
            col[i] = jac[i, j]
        lu_solve(cmat, n, piv, col, BAND)
        for i in range(n):
            rates[i, j] = col[i]
    w = np.linalg.eigvals(rates)
    smallest = np.inf
    largest = 0.0
    for v in w:
        smallest = min(smallest, v.real)
        largest = max(largest, abs(v))
    if smallest <= STABLE_RTOL * largest:
        return min(smallest, 0.0)
    return smallest


@kernel(inline="always")
def land(x_fold, direction, p_fold, sign, lattice, landing, x_land, info):
    """Where the finger comes to rest after snapping at the fold ``(x_fold, p_fold)``.

    ``direction`` is the branch tangent's position part at the fold (the direction of travel).
    ``lattice`` is a :class:`~.records.Lattice`; of the :class:`~.snap.records.Landing`,
    ``phys`` selects the model (node mass 0: overdamped), ``ctrl`` are the Rodas4 controls and
    ``kick`` (mm) the size of the first displacement along ``direction`` (``<= 0``:
    :func:`default_kick`). On success ``x_land``
    holds the equilibrium at ``p_fold`` and ``info`` (``N_LAND_INFO`` entries, read by the
    ``LAND_*`` indices: certificate, seconds simulated, Rodas4 steps, kick, pressure offset).
    Returns a status. Compiled inline into the walk (:func:`.snap.steps.snap`, its only caller):
    no machine code of its own.
    """
    unit_params, h = lattice
    phys, ctrl, kick = landing
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    y = np.empty(2 * n)
    biggest = 0.0
    for i in range(n):
        biggest = max(biggest, abs(direction[i]))
    if not biggest > 0.0:
        return st.DEGENERATE_GEOMETRY
    unit = np.empty(n)
    for i in range(n):
        unit[i] = direction[i] / biggest
    if not kick > 0.0:
        kick = default_kick(x_fold, unit, unit_params)
    info[LAND_KICK] = kick
    for i in range(n):
        y[i] = x_fold[i] + kick * unit[i]
        y[n + i] = 0.0
    knot_t = np.zeros(1)
    knot_p = np.zeros(1)
    rec = np.empty((n_units, N_REC))
    log = np.empty((0, 3))
    stats = np.zeros(N_STATS, dtype=np.int64)
    t_out = np.empty(0)
    x_out = np.empty((0, n))
    t = 0.0
    steps = 0
    for stage in range(len(LANDING_DP)):
        # A stage that does not settle goes on from where the motion got to, a little further
        # past the fold: a staircase of slow ramps through a very flat fold's bottleneck.
        offset = LANDING_DP[stage]
        knot_p[0] = p_fold + sign * offset
        local = ctrl.copy()
        chunk = FIRST_CHUNK
        stage_end = t + MAX_SETTLE
        while t < stage_end:
            code = rodas4(
                y,
                t,
                t + chunk,
                MotionModel(unit_params, h, knot_t, knot_p, phys),
                local,
                RunRecord(t_out, x_out, rec, log, stats),
            )
            steps += stats[STAT_STEPS]
            if code != st.OK:
                info[LAND_STEPS] = steps
                return code
            t += chunk
            local[CTRL_H_INIT] = chunk / 8.0  # the motion has slowed: no need to start at 1e-6 s
            chunk *= 2.0
            for i in range(n):
                x_land[i] = y[i]
            if (
                loaded_equilibrium(
                    x_land, unit_params, h, p_fold, POLISH_FTOL, POLISH_ITER, POLISH_MOVE
                )
                != st.OK
            ):
                continue
            moved = 0.0
            jump = 0.0
            for i in range(n):
                moved = max(moved, abs(x_land[i] - y[i]))
                jump = max(jump, abs(x_land[i] - x_fold[i]))
            if moved > POLISH_MAX or jump < JUMP_MIN * kick:
                continue
            cert = certify_stable(
                x_land, p_fold, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO]
            )
            if cert > 0.0:
                info[LAND_CERT] = cert
                info[LAND_SECONDS] = t
                info[LAND_STEPS] = steps
                info[LAND_OFFSET] = offset
                return st.OK
    info[LAND_STEPS] = steps
    return st.NOT_CONVERGED
