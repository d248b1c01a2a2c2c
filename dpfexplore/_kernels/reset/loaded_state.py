"""The finger at the end of a long pressure hold, found statically (the fast reset model's loading).

A pulse's loading and hold end, when the hold is long against the finger's slowest relaxation
(~1 /s), in the *loaded equilibrium* ``F_ext(x, P0) = ∇E(x)`` that the rising pressure led to:
which domes snapped through decides which equilibrium that is. :func:`loaded_state` finds both
without integrating the loading.

Which domes snap (the pattern)
    A dome snaps through under load when the pressure's push on it exceeds the largest
    restoring force on its way to the barrier, which sits near its isolated force peak
    ``u_peak`` (the smaller root of ``∂(force)/∂u = 0``, MODEL.md §4). So every dome that has
    not snapped is *held* at ``u = u_peak`` by a stiff penalty while the finger relaxes under
    ``P0`` around it (the snapped ones free, from an inverted guess); the penalty's reaction
    ``λ_k = k_pen (u_peak - u_k) d_k`` (N) is the force the hold supplies. ``λ_k < 0`` means the
    finger pushes dome ``k`` past its peak: it snaps. Those domes join the pattern and the
    round repeats (a snap curls the finger and changes the others' load) until no held dome
    wants to snap; then the holds are released and Newton settles the loaded equilibrium.
    Measured against the full loading dynamics on 8,000 random designs with low domes
    (``bench dynamics`` distribution, 0.7 MPa): the same snapped units on all but 5, each of
    those decided by ``|λ| < 0.005 N``; the fast model treats ``|λ| < 0.01 N`` as undecided.
Newton without an energy
    The pressure load follows the faces and is not conservative, so the equilibrium is a root
    of the force residual, solved by Newton on the banded LU of ``H - P_J`` with an Armijo
    search on ``½|R|²`` (:func:`loaded_newton`, also the polish of the release model's
    :func:`.reset.reduced.loaded_equilibrium` and of the snap landings). From the geometric guess
    with snapped domes extended by ``1.3 d`` (their loaded extension is ``1.05-1.25 d`` at
    0.7 MPa) it needs ~6 iterations.
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from .._jit import kernel
from ..dynamics.motion import N_PHYS, force_residual, stiffness_jacobian
from ..lattice import dome_extensions
from ..layout import (
    COL_ALPHA,
    COL_D,
    COL_KB,
    COL_P,
    COL_PEN,
    COL_U_HI,
    COL_U_INV,
    COL_U_LO,
    free_node,
    n_free,
    n_nodes,
)
from ..linalg.banded_lu import LATTICE_HALF_BANDWIDTH as BAND
from ..linalg.banded_lu import lu_factor, lu_solve
from ..records import MotionModel, MotionScratch

#: Extension (in units of ``d``) of the snapped domes in the geometric guess of a round.
SNAPPED_GUESS_EXTENSION = 1.3
#: Penalty stiffness of the hold at the force peak, relative to the dome's ``k_b``.
HOLD_PENALTY = 10.0
#: Newton controls: force tolerance (N) of the held rounds (a margin needs ~1e-4 N) and of the
#: released equilibrium the dynamics start from, iteration cap per solve, largest move (mm).
FTOL_ROUNDS = 1e-5
FTOL = 1e-7
MAX_ITER = np.int64(100)  # int64, not a literal: see the package docstring
MAX_MOVE = 100.0
#: Snapped-dome rounds before giving up (each round adds at least one dome: N + 1 suffice).
MAX_ROUNDS = 13


@kernel
def force_peak_extension(alpha):
    """``u`` of the isolated dome's force peak (MODEL.md §4); 0.25 when the force has none.

    The force ``k_b d u (1 + (1 - α)(2u² - 3u))`` has its local maximum where
    ``u² - u + 1/(6(1 - α)) = 0``, the smaller root.
    """
    disc = 1.0 - 2.0 / (3.0 * (1.0 - alpha))
    if disc <= 0.0:
        return 0.25
    return 0.5 * (1.0 - math.sqrt(disc))


@kernel
def extension_guess(unit_params, h, c, x):
    """Geometric guess with dome ``k`` lengthened by ``c[k]·d_k`` (per-unit version of MODEL.md §6).

    As :func:`.statics.states.geometric_guess`, with one extension factor per unit: each following
    post turns by ``atan(c_k d_k / h)`` about the unit's limiting-layer node.
    """
    n_units = unit_params.shape[0]
    cos_phi = 1.0
    sin_phi = 0.0
    lx = 0.0
    ly = h
    for k in range(1, n_units + 1):
        p = unit_params[k - 1, COL_P]
        lx += p * cos_phi
        ly += p * sin_phi
        lift = c[k - 1] * unit_params[k - 1, COL_D]
        inv_r = 1.0 / math.sqrt(h * h + lift * lift)
        cos_t = h * inv_r
        sin_t = lift * inv_r
        cos_phi, sin_phi = cos_phi * cos_t - sin_phi * sin_t, sin_phi * cos_t + cos_phi * sin_t
        fd = free_node(2 * k)
        x[2 * fd] = lx + h * sin_phi
        x[2 * fd + 1] = ly - h * cos_phi
        fl = free_node(2 * k + 1)
        if fl >= 0:
            x[2 * fl] = lx
            x[2 * fl + 1] = ly


@kernel
def newton_scratch(n_units):
    """Scratch arrays of :func:`loaded_newton` for ``n_units`` units."""
    n = n_free(n_units)
    nodes = n_nodes(n_units)
    return (
        np.empty((nodes, 2)),
        np.empty((nodes, 2)),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty((n, n)),
        np.empty(n, dtype=np.int64),
        np.zeros(n),
    )


@kernel
def loaded_newton(x, unit_params, h, pressure, ftol, max_iter, max_move, scratch):
    """Solve ``F_ext(x, P) = ∇E(x)`` in place from ``x`` by damped Newton.

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        Start; the equilibrium on return.
    unit_params, h
        Lattice tables (penalty columns included: a held dome's penalty enters both sides).
    pressure : float, MPa
    ftol : float, N
        Converged when the largest residual force is below it (or a step below 1e-11 mm).
    max_iter : int
        Cap on Jacobian factorisations; the point the last one leads to is still checked.
    max_move : float, mm
        Largest coordinate change per iteration.
    scratch : tuple
        From :func:`newton_scratch`.

    Returns
    -------
    status : int
        ``OK``, ``NOT_CONVERGED``, ``NONFINITE`` or ``DEGENERATE_GEOMETRY`` (singular Jacobian).
    n_iter : int
        Jacobian factorisations.
    """
    pos, vel, work, res, trial_res, step, trial, jac, piv, zero = scratch
    n = n_free(unit_params.shape[0])
    knot_t = np.zeros(1)
    knot_p = np.full(1, pressure)
    phys = np.zeros(N_PHYS)
    model = MotionModel(unit_params, h, knot_t, knot_p, phys)
    motion = MotionScratch(pos, vel, work)
    force_residual(x, zero, 0.0, model, motion, res)
    merit = 0.0
    for i in range(n):
        merit += res[i] * res[i]
    for it in range(max_iter + 1):
        if not math.isfinite(merit):
            return st.NONFINITE, it
        worst = 0.0
        for i in range(n):
            worst = max(worst, abs(res[i]))
        if worst < ftol:
            return st.OK, it
        if it == max_iter:
            break
        stiffness_jacobian(x, zero, 0.0, model, motion, jac)
        for i in range(n):
            for j in range(n):
                jac[i, j] = -jac[i, j]  # H - P_J: solve (H - P_J) dx = R
        if lu_factor(jac, n, piv, BAND) != 0:
            return st.DEGENERATE_GEOMETRY, it + 1
        for i in range(n):
            step[i] = res[i]
        lu_solve(jac, n, piv, step, BAND)
        biggest = 0.0
        for i in range(n):
            biggest = max(biggest, abs(step[i]))
        if biggest < 1e-11:
            return st.OK, it + 1  # converged to round-off: stiff posts keep |R| above ftol
        scale = min(1.0, max_move / biggest)
        trial_merit = merit
        accepted = False
        for _ in range(30):
            for i in range(n):
                trial[i] = x[i] + scale * step[i]
            force_residual(trial, zero, 0.0, model, motion, trial_res)
            trial_merit = 0.0
            for i in range(n):
                trial_merit += trial_res[i] * trial_res[i]
            # Armijo on ½|R|²: the Newton step is a descent direction for it
            if trial_merit <= (1.0 - 2e-4 * scale) * merit:
                accepted = True
                break
            scale *= 0.5
        if not accepted:
            return st.NOT_CONVERGED, it + 1
        for i in range(n):
            x[i] = trial[i]
            res[i] = trial_res[i]
        merit = trial_merit
    return st.NOT_CONVERGED, max_iter


@kernel
def loaded_state(unit_params, h, pressure, x, margin, u):
    """The pattern of snapped domes and the loaded equilibrium after a long hold at ``pressure``.

    Parameters
    ----------
    unit_params : ndarray of shape (N, N_COLS)
        The design's table (penalties off).
    h : float, mm
    pressure : float, MPa
        Hold pressure ``P0``.
    x : ndarray of shape (4N - 2,)
        Receives the loaded equilibrium (mm).
    margin : ndarray of shape (N,)
        Receives each dome's decision margin ``λ_k`` (N) from the round that decided it: the
        hold's reaction at the force peak, negative for a dome that snapped (the value of the
        round it snapped in), positive for one that did not (the last round). Its magnitude is
        how far the decision is from the boundary.
    u : ndarray of shape (N,)
        Receives the dome extensions ``x̄/d`` at the loaded equilibrium.

    Returns
    -------
    status : int
        ``OK``, a Newton failure, or ``NOT_CONVERGED`` when the released equilibrium's pattern
        differs from the rounds' (a dome crossed its barrier on release of the holds).
    pattern : int
        Snapped domes, unit 1 the most significant bit.
    n_iter : int
        Newton iterations over all solves.
    """
    n_units = unit_params.shape[0]
    scratch = newton_scratch(n_units)
    pos = scratch[0]
    held = unit_params.copy()
    peak = np.empty(n_units)
    c = np.empty(n_units)
    snapped = np.zeros(n_units, dtype=np.bool_)
    for k in range(n_units):
        peak[k] = force_peak_extension(unit_params[k, COL_ALPHA])
    total = 0
    settled = False
    for _ in range(MAX_ROUNDS):
        for k in range(n_units):
            held[k, COL_U_LO] = unit_params[k, COL_U_LO]
            held[k, COL_U_HI] = unit_params[k, COL_U_HI]
            held[k, COL_PEN] = unit_params[k, COL_PEN]
            if snapped[k]:
                c[k] = SNAPPED_GUESS_EXTENSION
            else:
                held[k, COL_U_LO] = peak[k]
                held[k, COL_U_HI] = peak[k]
                held[k, COL_PEN] = HOLD_PENALTY * unit_params[k, COL_KB]
                c[k] = peak[k]
        extension_guess(unit_params, h, c, x)
        code, it = loaded_newton(x, held, h, pressure, FTOL_ROUNDS, MAX_ITER, MAX_MOVE, scratch)
        total += it
        if code != st.OK:
            return code, -1, total
        dome_extensions(x, held, h, pos, u)
        more = False
        for k in range(n_units):
            if not snapped[k]:
                margin[k] = held[k, COL_PEN] * (peak[k] - u[k]) * unit_params[k, COL_D]
                if margin[k] < 0.0:
                    more = True
        if not more:
            settled = True
            break
        for k in range(n_units):
            if not snapped[k] and margin[k] < 0.0:
                snapped[k] = True
    if not settled:
        return st.NOT_CONVERGED, -1, total
    # release the holds: the unsnapped domes settle below their peaks
    code, it = loaded_newton(x, unit_params, h, pressure, FTOL, MAX_ITER, MAX_MOVE, scratch)
    total += it
    if code != st.OK:
        return code, -1, total
    dome_extensions(x, unit_params, h, pos, u)
    pattern = 0
    for k in range(n_units):
        pattern = 2 * pattern + (1 if snapped[k] else 0)
        if (u[k] > unit_params[k, COL_U_INV]) != snapped[k]:
            return st.NOT_CONVERGED, pattern, total
    return st.OK, pattern, total
