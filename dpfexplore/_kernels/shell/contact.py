"""A flat wall in the shell's way: penalty contact and the state resting against it (Numba).

The wall is the plane ``z = wall.z`` across the axis, below the base plane (``z = 0``), on the
side into which the inverted dome bulges; it faces ``+z``. The shell's facing surface at node
``k`` lies ``wall.offset`` (half the thickness) below the node, measured along the axis: the
node's normal is taken as the axis, which holds where an inverted cap touches a flat wall, near
its apex. A penetration ``g_k = wall.z − (z_k − wall.offset) > 0`` costs
``½ wall.modulus · A_k · g_k²``, ``A_k = wall.area[k]`` (a Winkler layer: pressure
``modulus · g``); the wall's reaction is ``Σ modulus · A_k · g_k`` (N). The energy is ``C¹``
in the node positions, its Hessian (``modulus · A_k`` on the diagonal of the touching nodes'
``z``) jumps where a node starts to touch.

:func:`rest_on_wall` minimises the shell's energy plus the wall's with the apex free (``δ``
an unknown): the dome resting against the wall with no apex load, as after an inversion by
pressure that was then released. It is :func:`.path.relax` with the wall's terms added,
and stalls at round-off like it; :func:`polish_on_wall` (Newton, as
:func:`.path.equilibrate_free`) finishes from there.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..linalg.band_storage import band_newton_step, band_solve, negative_pivots
from .energy import BAND, assemble


@kernel
def wall_energy(y, geom, wall, grad, band, want):
    """Add the wall's energy terms to ``grad`` and ``band`` (``want`` as in ``assemble``).

    Returns ``(energy, reaction)``: the penalty energy (N·mm) and the wall's reaction (N).
    """
    n = geom.r0.shape[0] - 1
    energy = 0.0
    reaction = 0.0
    for k in range(n):  # node n is held on the base plane
        if k == 0:
            z = geom.z0[0] - y[0]
            i = 0
            dg = 1.0  # z_0 = z0_0 - δ
        else:
            z = y[2 * k]
            i = 2 * k
            dg = -1.0
        g = wall.z - (z - wall.offset)
        if g > 0.0:
            w = wall.modulus * wall.area[k]
            energy += 0.5 * w * g * g
            reaction += w * g
            if want >= 1:
                grad[i] += w * g * dg
            if want >= 2:
                band[i, BAND] += w
    return energy, reaction


@kernel
def assemble_wall(y, geom, wall, grad, band, want):
    """The shell's energy with the wall's: ``(membrane, bending, wall energy, reaction)``."""
    membrane, bending = assemble(y, geom, grad, band, want)
    contact, reaction = wall_energy(y, geom, wall, grad, band, want)
    return membrane, bending, contact, reaction


@kernel
def rest_on_wall(y, geom, wall, ftol, max_iter):
    """Minimise the energy with the wall, ``δ`` free, from ``y`` (in place).

    Newton with a Levenberg shift and backtracking on the energy (:func:`.path.relax`).
    Returns ``(iterations or -1, negative eigenvalues of the unshifted Hessian at the result)``.
    """
    m = y.shape[0]
    g = np.zeros(m)
    band = np.zeros((m, 2 * BAND + 1))
    work = np.zeros((m, 2 * BAND + 1))
    w = np.zeros((m, 3 * BAND + 1))
    piv = np.zeros(m, dtype=np.int64)
    b = np.zeros(m)
    trial = np.zeros(m)
    scratch = np.zeros(m)
    mu = 0.0
    for it in range(max_iter):
        em, eb, ec, _ = assemble_wall(y, geom, wall, g, band, 2)
        energy = em + eb + ec
        res = 0.0
        diag = 0.0
        for j in range(m):
            res = max(res, abs(g[j]))
            diag = max(diag, abs(band[j, BAND]))
        if res <= ftol:
            return it, negative_pivots(band, 0, BAND, work)
        for _ in range(60):
            shifted = band.copy()
            for j in range(m):
                shifted[j, BAND] += mu
            if negative_pivots(shifted, 0, BAND, work) != 0:
                mu = max(4.0 * mu, 1e-8 * diag)
                continue
            for j in range(m):
                b[j] = -g[j]
            if band_solve(shifted, w, piv, b) != 0:
                mu = max(4.0 * mu, 1e-8 * diag)
                continue
            slope = 0.0
            for j in range(m):
                trial[j] = y[j] + b[j]
                slope += g[j] * b[j]
            tm, tb, tc, _ = assemble_wall(trial, geom, wall, scratch, work, 0)
            if tm + tb + tc <= energy + 1e-4 * slope or (tm + tb + tc - energy) <= 1e-14 * abs(
                energy
            ):
                y[:] = trial
                mu *= 0.25
                break
            mu = max(4.0 * mu, 1e-8 * diag)
        else:
            return -1, -1
    return -1, -1


@kernel
def polish_on_wall(y, geom, wall, ftol, xtol):
    """Newton on the gradient with the wall, ``δ`` free, from a nearby ``y`` (in place).

    Returns ``(iterations or -1, negative eigenvalues of the Hessian at the result)``; on -1
    ``y`` is left where Newton stopped.
    """
    m = y.shape[0]
    g = np.zeros(m)
    band = np.zeros((m, 2 * BAND + 1))
    work = np.zeros((m, 2 * BAND + 1))
    w = np.zeros((m, 3 * BAND + 1))
    piv = np.zeros(m, dtype=np.int64)
    b = np.zeros(m)
    previous = np.inf
    for it in range(20):
        assemble_wall(y, geom, wall, g, band, 2)
        res = 0.0
        for j in range(m):
            res = max(res, abs(g[j]))
        if res <= ftol and it > 0:
            return it, negative_pivots(band, 0, BAND, work)
        dn = band_newton_step(band, g, y, w, piv, b)
        if dn < 0.0 or not dn < np.inf:
            return -1, -1
        if dn <= xtol:
            assemble_wall(y, geom, wall, g, band, 2)
            return it + 1, negative_pivots(band, 0, BAND, work)
        if it >= 3 and dn > 0.5 * previous:
            return -1, -1
        previous = dn
    return -1, -1
