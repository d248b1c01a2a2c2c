"""Equilibrium path of a shell under apex displacement control: continuation (Numba).

Equilibrium at apex travel ``δ``: ``g_j(y) = ∂Π/∂y_j = 0`` for the free unknowns ``j >= 1``
(:mod:`.shell.energy`); the apex reaction is ``F = ∂Π/∂δ = g_0``. The path ``y(s)`` is one curve in
the ``m``-dimensional space of ``y = (δ, x)``; where it folds in ``δ`` (a snap-back under
displacement control) the Hessian of the free unknowns is singular and plain displacement
control stops, so the path is followed by **local parametrisation** (Rheinboldt's PITCON): each
step fixes the unknown ``y_p`` with the largest tangent component (``δ`` itself while its
component is at least :data:`PREFER_DELTA` of the largest) and solves ``g_j = 0`` for the rest.

Corrector matrix
    The free equations' Jacobian (rows ``1..m-1`` of the Hessian) with the unit row ``e_p``
    added. Placing ``e_p`` at row ``p`` and shifting the rows above it up by one keeps it banded
    (lower bandwidth ``b``, upper ``b + 1``), regular wherever ``t_p != 0``, folds included;
    factored by the banded LU of :mod:`.linalg.band_storage`.
Tangent
    The same matrix with right-hand side ``e_p`` gives ``z`` with ``z_p = 1`` in the null space
    of the free equations' Jacobian; normalised in the weighted norm
    ``‖y‖² = δ² + Σ_k (r_k² + z_k²) / (N - 1)`` (apex travel against the mean node motion) and
    oriented along the previous tangent.
Steps
    Predictor ``y + h t``, Newton with the exact Hessian. A step is refused (and ``h`` halved)
    when Newton fails or does not contract, moves further than ``h`` from the predictor, or the
    tangent turns by more than :data:`MAX_TURN` (guards against jumping to another branch) or
    the force-travel curve by more than :data:`MAX_CURVE_TURN` (resolves the folds);
    ``h`` grows by 1.5 after an easy step up to ``h_max``.
Stability
    The number of negative eigenvalues of the free Hessian at fixed ``δ`` (Sylvester inertia of
    its band), recorded at every point: 0 is stable under displacement control.
Free equilibria
    :func:`equilibrate_free` (Newton on all unknowns, ``δ`` included: a zero-force state, stable
    or not) and :func:`relax` (energy minimisation from a far start, e.g. the dome's mirror
    image, with a Levenberg shift and backtracking).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..linalg.band_storage import (
    band_lu,
    band_lu_solve,
    band_newton_step,
    band_solve,
    negative_pivots,
)
from .energy import BAND, assemble
from .records import PathPoints, PathScratch

KL = BAND
KU = BAND + 1
WIDTH = 2 * KL + KU + 1
#: Keep ``δ`` as the parameter while ``|t_δ| >= PREFER_DELTA · max |t|``.
PREFER_DELTA = 0.3
#: Largest tangent turn of an accepted step: ``cos`` of the angle between successive tangents.
MAX_TURN = 0.9
#: Largest turn of the curve ``(δ, F / k0)`` in one step (``cos`` 20°; ``k0`` the path's first
#: stiffness): resolves the folds, where ``δ`` and ``F`` turn faster than the shape does.
MAX_CURVE_TURN = 0.94
#: Newton iterations of one corrector.
MAX_ITER = 12
#: The unknown ``δ`` (index 0 of ``y``), and the first free unknown: the first row of the free
#: Hessian. int64, not literals: see the package docstring.
DELTA = np.int64(0)
FIRST_FREE = np.int64(1)
# assemble's ``want`` stays a literal on purpose (2: the Hessian, 0: the energy alone): each
# level compiles its own assembly without the other levels' branches (an int64 compiles once,
# faster, but leaves every level's branches in every path).

#: Status codes of :func:`follow`.
REACHED = 0
MAX_STEPS = 1
BACKWARD = 2
STEP_TOO_SMALL = 3
FOLD = 4


@kernel
def _jacobian(band, p, w):
    """Rows ``1..m-1`` of the Hessian band with the unit row ``e_p``, shifted to stay banded."""
    m = band.shape[0]
    w[:, :] = 0.0
    for i in range(m):
        if i == p:
            w[i, KL] = 1.0
            continue
        s = i + 1 if i < p else i
        for k in range(-BAND, BAND + 1):
            j = s + k
            if 0 <= j < m:
                w[i, j - i + KL] = band[s, BAND + k]


@kernel
def _rhs(g, p, b, scale):
    """``-g`` of the free equations in the row order of :func:`_jacobian`; ``scale`` at row p."""
    m = g.shape[0]
    for i in range(m):
        if i == p:
            b[i] = scale
        elif i < p:
            b[i] = -g[i + 1]
        else:
            b[i] = -g[i]


@kernel
def _wdot(a, b, wn):
    s = 0.0
    for j in range(1, a.shape[0]):
        s += a[j] * b[j]
    return a[0] * b[0] + wn * s


@kernel
def _choose(t):
    big = 0.0
    p = 0
    for j in range(t.shape[0]):
        v = abs(t[j])
        if v > big:
            big = v
            p = j
    if abs(t[0]) >= PREFER_DELTA * big:
        return 0
    return p


@kernel
def _free_residual(g, p):
    """Largest free-equation residual (row 0 is the reaction; ``p`` is not an equation)."""
    res = 0.0
    for j in range(1, g.shape[0]):
        res = max(res, abs(g[j]))
    return res


@kernel
def correct(y, p, geom, controls, scratch):
    """Newton on the free equations with ``y_p`` fixed; ``y`` is updated in place.

    Reads the tolerances ``ftol``, ``xtol`` of the :data:`~.shell.records.PathControls`
    ``controls`` and works in the :data:`~.shell.records.PathScratch` ``scratch`` (its ``g`` and
    ``band`` are left assembled at the result). Returns the number of iterations, or -1 if the
    corrector failed.
    """
    ftol = controls.ftol
    xtol = controls.xtol
    g, band, w, piv, b = scratch.g, scratch.band, scratch.w, scratch.piv, scratch.b
    m = y.shape[0]
    previous = math.inf
    for it in range(MAX_ITER):
        assemble(y, geom, g, band, 2)
        if _free_residual(g, p) <= ftol and it > 0:
            return it
        _jacobian(band, p, w)
        if band_lu(w, m, KL, KU, piv) != 0:
            return -1
        _rhs(g, p, b, 0.0)
        band_lu_solve(w, m, KL, KU, piv, b)
        b[p] = 0.0  # the parameter stays exactly where the step put it (not off by round-off)
        dn = 0.0
        for j in range(m):
            y[j] += b[j]
            dn = max(dn, abs(b[j]))
        if not dn < math.inf:
            return -1
        if dn <= xtol:
            assemble(y, geom, g, band, 2)
            return it + 1
        if it >= 2 and dn > 0.5 * previous:
            return -1
        previous = dn
    return -1


@kernel
def tangent(y, p, t_prev, wn, scratch, t):
    """Unit tangent ``t`` at the equilibrium ``y`` (``scratch.band`` already assembled there).

    Oriented along ``t_prev``; ``wn`` weighs the nodes in the norm. Returns 0, or 1 if the
    matrix is singular.
    """
    band, w, piv = scratch.band, scratch.w, scratch.piv
    m = y.shape[0]
    _jacobian(band, p, w)
    if band_lu(w, m, KL, KU, piv) != 0:
        return 1
    t[:] = 0.0
    t[p] = 1.0
    band_lu_solve(w, m, KL, KU, piv, t)
    norm = math.sqrt(_wdot(t, t, wn))
    sign = 1.0 if _wdot(t, t_prev, wn) >= 0.0 else -1.0
    for j in range(m):
        t[j] *= sign / norm
    return 0


@kernel
def follow(geom, y0, travel, controls, direction, stop_at_fold):
    """Follow the path from the equilibrium ``y0`` (at ``δ = y0[0]``).

    Parameters
    ----------
    geom : ShellGeometry
        The shell (:mod:`.shell.records`).
    y0 : ndarray (m,)
        The start: an equilibrium at its own ``δ`` (corrected here at that ``δ``).
    travel : float, mm
        Apex travel at which the path stops.
    controls : PathControls
        Steps ``h0``, ``h_max``, ``h_min`` (mm of weighted arclength), the step cap
        ``max_steps`` (int) and the corrector's tolerances ``ftol`` (N), ``xtol`` (mm).
    direction : float
        Start toward larger ``δ`` (``1.0``) or smaller (``-1.0``).
    stop_at_fold : bool
        Stop at the first point past a fold in ``δ``.

    Returns
    -------
    status : int
        :data:`REACHED` (``δ >= travel``), :data:`MAX_STEPS` (``max_steps`` steps taken),
        :data:`BACKWARD` (the path went below ``δ = -travel/20``), :data:`STEP_TOO_SMALL` (the
        step fell below ``h_min``) or :data:`FOLD` (with ``stop_at_fold``).
    n : int
        Number of recorded points (``y0`` included).
    points : PathPoints
        The recorded points in the first ``n`` of their ``max_steps + 1`` rows: ``ys``, unit
        tangents ``ts``, ``energy`` (membrane, bending; N·mm), apex reaction ``force``
        ``F = ∂Π/∂δ`` (N), ``slope`` ``dF/ds`` along the tangent (N per mm of ``s``) and
        ``index``, the negative eigenvalues of the free Hessian (-1: singular).
    """
    h_max = controls.h_max
    h_min = controls.h_min
    max_steps = controls.max_steps
    m = y0.shape[0]
    n_nodes = (m + 1) // 2 + 1
    wn = 1.0 / (n_nodes - 2)
    points = PathPoints(
        np.zeros((max_steps + 1, m)),
        np.zeros((max_steps + 1, m)),
        np.zeros((max_steps + 1, 2)),
        np.zeros(max_steps + 1),
        np.zeros(max_steps + 1),
        np.zeros(max_steps + 1, dtype=np.int64),
    )
    slope = points.slope
    scratch = PathScratch(
        np.zeros(m),
        np.zeros((m, 2 * BAND + 1)),
        np.zeros((m, WIDTH)),
        np.zeros(m, dtype=np.int64),
        np.zeros(m),
        np.zeros((m, 2 * BAND + 1)),
    )
    band, b = scratch.band, scratch.b
    y = y0.copy()
    t = np.zeros(m)
    t_new = np.zeros(m)
    t[0] = direction
    n = np.int64(0)
    status = MAX_STEPS

    # First point: correct y0 at fixed δ (a no-op at the reference state).
    if correct(y, DELTA, geom, controls, scratch) < 0:
        return STEP_TOO_SMALL, 0, points
    if tangent(y, DELTA, t, wn, scratch, t_new) != 0:
        return STEP_TOO_SMALL, 0, points
    t[:] = t_new
    _record(y, t, geom, scratch, n, points)
    n = np.int64(1)
    h = controls.h0
    y_try = np.zeros(m)
    k0 = abs(slope[0] / t[0]) if t[0] != 0.0 else 0.0
    fscale = 1.0 / k0 if k0 > 0.0 else 0.0
    while n <= max_steps:
        if h < h_min:
            status = STEP_TOO_SMALL
            break
        p = _choose(t)
        for j in range(m):
            y_try[j] = y[j] + h * t[j]
        its = correct(y_try, p, geom, controls, scratch)
        ok = its >= 0
        if ok:
            # distance from the predictor, weighted: a larger jump may have changed branch
            for j in range(m):
                b[j] = y_try[j] - y[j] - h * t[j]
            ok = math.sqrt(_wdot(b, b, wn)) <= h
        if ok:
            ok = tangent(y_try, p, t, wn, scratch, t_new) == 0
        if ok:
            ok = _wdot(t_new, t, wn) >= MAX_TURN or h <= 2.0 * h_min
        if ok and fscale > 0.0:
            s_new = 0.0
            for k in range(-BAND, BAND + 1):
                if 0 <= k < m:
                    s_new += band[0, BAND + k] * t_new[k]
            a0, a1 = t[0], slope[n - 1] * fscale
            b0, b1 = t_new[0], s_new * fscale
            cos = (a0 * b0 + a1 * b1) / math.sqrt((a0 * a0 + a1 * a1) * (b0 * b0 + b1 * b1))
            ok = cos >= MAX_CURVE_TURN or h <= 2.0 * h_min
        if not ok:
            h *= 0.5
            continue
        y[:] = y_try
        t[:] = t_new
        # the tangent solve reused w; g and band still hold the converged point's values
        _record(y, t, geom, scratch, n, points)
        n += 1
        if y[0] >= travel:
            status = REACHED
            break
        if stop_at_fold and t[0] * direction < 0.0:
            status = FOLD
            break
        if y[0] < -travel / 20.0:
            status = BACKWARD
            break
        if its <= 3:
            h = min(h_max, 1.5 * h)
        elif its >= 6:
            h *= 0.7
    return status, n, points


@kernel
def _record(y, t, geom, scratch, n, points):
    """Write the point ``y`` and its tangent ``t`` to row ``n`` of ``points``.

    ``scratch.band`` holds the Hessian at ``y`` (its reaction row gives the slope, its free
    rows the inertia); the energy is assembled here.
    """
    band = scratch.band
    points.ys[n, :] = y
    points.ts[n, :] = t
    em, eb = assemble(y, geom, scratch.g, band, 0)
    points.energy[n, 0] = em
    points.energy[n, 1] = eb
    points.force[n] = scratch.g[0]
    s = 0.0
    for k in range(-BAND, BAND + 1):
        if 0 <= k < y.shape[0]:
            s += band[0, BAND + k] * t[k]
    points.slope[n] = s
    points.index[n] = negative_pivots(band, FIRST_FREE, BAND, scratch.work)


@kernel
def equilibrate_free(y, geom, ftol, xtol):
    """Newton on all of ``∂Π/∂y = 0`` (``δ`` free: zero apex force); ``y`` updated in place.

    Returns ``(iterations or -1, negative eigenvalues of the full Hessian)``.
    """
    m = y.shape[0]
    g = np.zeros(m)
    band = np.zeros((m, 2 * BAND + 1))
    work = np.zeros((m, 2 * BAND + 1))
    w = np.zeros((m, 2 * BAND + BAND + 1))
    piv = np.zeros(m, dtype=np.int64)
    b = np.zeros(m)
    previous = math.inf
    for it in range(MAX_ITER + 8):
        assemble(y, geom, g, band, 2)
        res = 0.0
        for j in range(m):
            res = max(res, abs(g[j]))
        if res <= ftol and it > 0:
            return it, negative_pivots(band, DELTA, BAND, work)
        dn = band_newton_step(band, g, y, w, piv, b)
        if dn < 0.0 or not dn < math.inf:
            return -1, -1
        if dn <= xtol:
            assemble(y, geom, g, band, 2)
            return it + 1, negative_pivots(band, DELTA, BAND, work)
        if it >= 3 and dn > 0.5 * previous:
            return -1, -1
        previous = dn
    return -1, -1


@kernel
def relax(y, geom, free_delta, ftol, max_iter):
    """Minimise the energy from ``y`` (in place): at fixed ``δ``, or with ``δ`` free too.

    Newton with a Levenberg shift ``μ I`` that keeps the step a descent direction (raised until
    the shifted Hessian is positive definite, lowered after every accepted step) and
    backtracking on the energy: reaches the local minimum from a far start (the dome's mirror
    image) where plain Newton diverges. Returns ``(iterations or -1, negative eigenvalues of
    the unshifted Hessian at the result)``.
    """
    m = y.shape[0]
    lo = 0 if free_delta else 1
    g = np.zeros(m)
    band = np.zeros((m, 2 * BAND + 1))
    work = np.zeros((m, 2 * BAND + 1))
    w = np.zeros((m, 2 * BAND + BAND + 1))
    piv = np.zeros(m, dtype=np.int64)
    b = np.zeros(m)
    trial = np.zeros(m)
    scratch = np.zeros(m)
    mu = 0.0
    for it in range(max_iter):
        em, eb = assemble(y, geom, g, band, 2)
        energy = em + eb
        res = 0.0
        diag = 0.0
        for j in range(lo, m):
            res = max(res, abs(g[j]))
            diag = max(diag, abs(band[j, BAND]))
        if res <= ftol:
            return it, negative_pivots(band, lo, BAND, work)
        for _ in range(60):
            work[:, :] = band
            for j in range(lo, m):
                work[j, BAND] += mu
            if lo == 1:  # δ fixed: its row and column are the identity
                work[0, :] = 0.0
                for k in range(1, BAND + 1):
                    work[k, BAND - k] = 0.0
                work[0, BAND] = 1.0
            shifted = work.copy()
            if negative_pivots(shifted, DELTA, BAND, work) != 0:
                mu = max(4.0 * mu, 1e-8 * diag)
                continue
            for j in range(m):
                b[j] = -g[j] if j >= lo else 0.0
            if band_solve(shifted, w, piv, b) != 0:
                mu = max(4.0 * mu, 1e-8 * diag)
                continue
            slope = 0.0
            for j in range(m):
                trial[j] = y[j] + b[j]
                slope += g[j] * b[j]
            tm, tb = assemble(trial, geom, scratch, work, 0)
            if tm + tb <= energy + 1e-4 * slope or (tm + tb - energy) <= 1e-14 * abs(energy):
                y[:] = trial
                mu *= 0.25
                break
            mu = max(4.0 * mu, 1e-8 * diag)
        else:
            return -1, -1
    return -1, -1
