"""Equilibrium branches under a quasi-static chamber pressure: pseudo-arclength continuation.

A finger held at chamber pressure ``P`` (MPa) and at rest is in equilibrium when

    R(x, P) = ∇E(x) - P f(x) = 0,

with ``f(x)`` the pressure load of MODEL.md §8 at unit pressure (N/MPa: each face's length along
its normal, half to each end node; :func:`.dynamics.motion.add_pressure_forces`). ``f`` is affine in
the positions, so ``∂R/∂x = K = H(x) - P J_p`` with ``J_p`` constant (:func:`.dynamics.motion.
add_pressure_jacobian`) and ``∂R/∂P = -f(x)``. The load follows the faces and is not the
gradient of a potential (the posts are pushed toward the tip with no opposite push on the next
chamber's back wall), so ``K`` is not symmetric.

Branch coordinates
    ``y = (x, p̃)`` with ``p̃ = PRESSURE_SCALE · P``: positions in mm, pressure scaled to mm so
    that the arclength weighs both (a finger moves a few mm per 0.1 MPa).
Corrector
    Keller's pseudo-arclength: from a point ``y0`` with unit tangent ``t0`` and a step ``σ``,
    Newton on ``[R(y); t0·(y - y0) - σ] = 0`` from the predictor ``y0 + σ t0``. Its matrix, the
    bordered ``[[K, -f/PRESSURE_SCALE], [t0ᵀ]]``, stays regular through a fold (where ``K`` is
    singular), so the branch is followed around it. Factored by the bordered banded LU of
    :mod:`.linalg.bordered_lu` (the border row stays a pivot candidate, so folds are safe).
Tangent
    The same factorisation at the converged point gives the next tangent: ``[[K, -f/w], [t0ᵀ]]
    z = e_last``, normalised; ``t0·z = 1`` orients it along the direction of travel.
Fold
    Where the branch turns back in pressure the tangent's pressure component changes sign: that
    is a real eigenvalue of ``K`` crossing zero (``K t_x = (f/w) t_p`` with ``t_p = 0``).
Locating events inside a step
    :func:`locate` finds the arclength of a sign change inside an accepted step by the Illinois
    method, every trial point corrected onto the branch from the step's start: the fold as the
    zero of the tangent's pressure component, a unit's inversion as the zero of its threshold
    margin ``u - u_inv``, the end of the ramp as ``P - P_end``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..dynamics.events import margins
from ..dynamics.motion import add_pressure_forces, add_pressure_jacobian
from ..lattice import GRADIENT, HESSIAN, N_SPLIT, assemble
from ..layout import n_free, n_nodes
from ..linalg.banded_lu import LATTICE_HALF_BANDWIDTH as BAND
from ..linalg.bordered_lu import bordered_factor, bordered_solve

#: Scale of the pressure coordinate on the branch, mm per MPa.
PRESSURE_SCALE = 10.0
#: ``residual``'s ``want_jacobian`` from the kernels: a NumPy bool, not the literal ``True``,
#: so they share the one compiled ``residual`` that Python's calls (with a bool) compile.
WITH_JACOBIAN = np.bool_(True)
#: Corrector converged: largest residual force (N) below this ...
FTOL = 1e-9
#: ... or the last Newton correction (mm) below this (stiff posts keep |R| at round-off).
XTOL = 1e-11
#: Newton iterations of one corrector before the step is declared failed.
MAX_CORRECTOR_ITER = 8
#: A correction larger than this fraction of the previous one: not converging, shorten the step.
CONTRACTION = 0.5
#: Iterations of the Illinois search for an event inside a step.
LOCATE_ITER = 80
#: Arclength bracket (mm, scaled) at which an event is located, or an event function this
#: small: ``|t_p| <= FOLD_TOL`` at a fold, whose pressure is quadratic in the arclength there
#: (``P* - P ~ t_p²/(4 a)``, ~1e-13 MPa for the lattices here, far below the corrector's
#: ~1e-10 MPa); ``|u - u_inv| <= MARGIN_TOL`` at a crossing; ``|p̃ - p̃_end| <= END_TOL`` mm.
SIGMA_TOL = 1e-10
FOLD_TOL = 1e-7
MARGIN_TOL = 1e-11
END_TOL = 1e-10

#: Event functions of :func:`locate` besides a unit's margin (unit index ``k >= 0``).
WHICH_FOLD = np.int64(-1)  # int64, not literals: see the package docstring
WHICH_END = np.int64(-2)


@kernel
def workspace(n_units):
    """Scratch of one branch: ``(pos, res, f, jac, big, piv, rhs, split, g)``.

    ``res`` ``R`` (N), ``f`` the load at unit pressure (N/MPa), ``jac`` ``K`` (N/mm), ``big`` the
    bordered matrix, ``g`` unit margins.
    """
    n = n_free(n_units)
    return (
        np.empty((n_nodes(n_units), 2)),
        np.empty(n),
        np.empty(n),
        np.empty((n, n)),
        np.empty((n + 1, n + 1)),
        np.empty(n + 2, dtype=np.int64),
        np.empty(n + 1),
        np.empty(N_SPLIT),
        np.empty(n_units),
    )


@kernel
def residual(x, pressure, unit_params, h, ws, want_jacobian):
    """``R = ∇E - P f`` into ``ws`` (and ``K = H - P J_p`` if ``want_jacobian``).

    Returns the largest ``|R_i|`` (N); NaN if any entry is not finite.
    """
    pos, res, f, jac, _, _, _, split, _ = ws
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    mode = HESSIAN if want_jacobian else GRADIENT
    assemble(x, unit_params, h, pos, res, jac, mode, split)
    for i in range(n):
        f[i] = 0.0
    add_pressure_forces(pos, n_units, 1.0, f)
    biggest = 0.0
    for i in range(n):
        r = res[i] - pressure * f[i]
        res[i] = r
        if not math.isfinite(r):
            return np.nan
        biggest = max(biggest, abs(r))
    if want_jacobian:
        add_pressure_jacobian(n_units, -pressure, jac)
    return biggest


@kernel
def _factor_bordered(border, ws, n):
    """LU of ``[[K, -f/w], [borderᵀ]]`` (``K``, ``f`` from the last :func:`residual`)."""
    _, _, f, jac, big, piv, _, _, _ = ws
    inv_w = 1.0 / PRESSURE_SCALE
    for i in range(n):
        for j in range(n):
            big[i, j] = jac[i, j]
        big[i, n] = -f[i] * inv_w
    for j in range(n + 1):
        big[n, j] = border[j]
    return bordered_factor(big, n + 1, piv, BAND)


@kernel
def _tangent(ws, n, t):
    """Unit tangent from the current bordered factorisation (``t0·z = 1`` orients it)."""
    _, _, _, _, big, piv, rhs, _, _ = ws
    for i in range(n):
        rhs[i] = 0.0
    rhs[n] = 1.0
    bordered_solve(big, n + 1, piv, rhs, BAND)
    norm = 0.0
    for i in range(n + 1):
        norm += rhs[i] * rhs[i]
    norm = math.sqrt(norm)
    if not (norm > 0.0 and math.isfinite(norm)):
        return False
    for i in range(n + 1):
        t[i] = rhs[i] / norm
    return True


#: Corrector outcomes.
CORRECT_OK = 0
CORRECT_FAILED = 1  # no convergence within MAX_CORRECTOR_ITER, or not contracting
CORRECT_SINGULAR = 2  # the bordered matrix is singular (a branch point) or not finite


@kernel
def correct(y0, t0, sigma, unit_params, h, ws, y, t):
    """Point ``y`` at pseudo-arclength ``sigma`` from ``y0`` along ``t0``, and its tangent ``t``.

    ``sigma = 0`` with ``t0 = ±e_p`` polishes ``x`` at the pressure of ``y0`` and gives the
    tangent pointing toward rising (``+``) or falling (``-``) pressure. Returns
    ``(CORRECT_*, Newton iterations)``.
    """
    n = y0.shape[0] - 1
    _, res, _, _, big, piv, rhs, _, _ = ws
    for i in range(n + 1):
        y[i] = y0[i] + sigma * t0[i]
    last = np.inf
    for it in range(MAX_CORRECTOR_ITER + 1):
        biggest = residual(y[:n], y[n] / PRESSURE_SCALE, unit_params, h, ws, WITH_JACOBIAN)
        if not math.isfinite(biggest):
            return CORRECT_SINGULAR, it
        if _factor_bordered(t0, ws, n) != 0:
            return CORRECT_SINGULAR, it
        if biggest <= FTOL or last <= XTOL:
            if not _tangent(ws, n, t):
                return CORRECT_SINGULAR, it
            return CORRECT_OK, it
        if it == MAX_CORRECTOR_ITER:
            break
        arc = -sigma
        for i in range(n + 1):
            arc += t0[i] * (y[i] - y0[i])
        for i in range(n):
            rhs[i] = -res[i]
        rhs[n] = -arc
        bordered_solve(big, n + 1, piv, rhs, BAND)
        size = 0.0
        for i in range(n + 1):
            y[i] += rhs[i]
            size = max(size, abs(rhs[i]))
        if not math.isfinite(size):
            return CORRECT_SINGULAR, it
        if it >= 1 and size > CONTRACTION * last:
            return CORRECT_FAILED, it
        last = size
    return CORRECT_FAILED, MAX_CORRECTOR_ITER


@kernel
def event_value(which, y, t, unit_params, p_end_scaled, g):
    """Event function at a branch point: fold ``t_p``, end ``p̃ - p̃_end``, or unit margin."""
    n = y.shape[0] - 1
    if which == WHICH_FOLD:
        return t[n]
    if which == WHICH_END:
        return y[n] - p_end_scaled
    margins(y[:n], unit_params, g)
    return g[which]


@kernel
def locate(which, start, bracket, lattice, p_end_scaled, ws, out):
    """Arclength in ``(s_lo, s_hi)`` where event ``which`` changes sign (Illinois method).

    The step runs from the :class:`~.records.BranchPoint` ``start``; ``bracket`` is a
    :class:`~.records.Bracket` (the event values at its ends have opposite signs); ``lattice``
    a :class:`~.records.Lattice`. On return ``out`` (a :class:`~.records.BranchPoint`) holds the
    branch point and tangent at the returned arclength. Returns ``(status, s)``; status is a
    ``CORRECT_*`` code.
    """
    y0, t0 = start
    s_lo, g_lo, s_hi, g_hi = bracket
    unit_params, h = lattice
    y, t = out
    g = ws[8]
    if which == WHICH_FOLD:
        tol = FOLD_TOL
    elif which == WHICH_END:
        tol = END_TOL
    else:
        tol = MARGIN_TOL
    s = 0.5 * (s_lo + s_hi)
    side = 0
    evaluated = False
    for _ in range(LOCATE_ITER):
        s = (s_lo * g_hi - s_hi * g_lo) / (g_hi - g_lo)
        if not (s_lo < s < s_hi):
            s = 0.5 * (s_lo + s_hi)
        code, _ = correct(y0, t0, s, unit_params, h, ws, y, t)
        if code != CORRECT_OK:
            return code, s
        evaluated = True
        gs = event_value(which, y, t, unit_params, p_end_scaled, g)
        if abs(gs) <= tol:
            break
        if (gs > 0.0) == (g_hi > 0.0):
            s_hi = s
            g_hi = gs
            if side == 1:
                g_lo *= 0.5
            side = 1
        else:
            s_lo = s
            g_lo = gs
            if side == -1:
                g_hi *= 0.5
            side = -1
        if s_hi - s_lo <= SIGMA_TOL:
            break
    if not evaluated:
        code, _ = correct(y0, t0, s, unit_params, h, ws, y, t)
        return code, s
    return CORRECT_OK, s
