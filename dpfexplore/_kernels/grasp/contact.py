"""The disk against the finger's inner surface: gap, penalty and the energy with contact.

Geometry
    The inner surface is the limiting layer's side (MODEL.md §5: the finger curls toward +y),
    the polyline ``L_0 … L_N`` moved by ``offset`` (half the layer's thickness: the nodes lie on
    its mid-line) toward the disk. Each segment ``L_{k-1}–L_k`` has its own gap: where the
    centre's projection falls inside the segment, the signed distance from the centre to the
    segment's line (``cross(B - A, c - A) / |B - A|``, positive on the inner side) minus the
    radius and the offset; beyond an end, the distance to that end node. The gap is smooth in
    each region and C¹ across their border; its gradient and Hessian in the segment's nodes are
    exact in each region.
Penalty
    ``ψ(γ)`` of the shifted gap ``γ = g - σ``: zero for ``γ >= 0``, ``-κ γ³ / (6 ε)`` on
    ``-ε < γ < 0`` and ``κ (γ²/2 + ε γ/2 + ε²/6)`` below: C², convex, its curvature rising
    linearly from 0 to ``κ`` over the width ``ε``. The contact force on the disk is
    ``f = -ψ'(γ) >= 0``, along the surface's normal. The shift ``σ`` is the augmented
    Lagrangian's multiplier over ``κ`` (:mod:`.equilibrium` updates it), so the penetration goes
    to zero without ``κ`` going to infinity.
Friction
    Coulomb friction enters as a dead load on the finger at the contact point (held fixed during
    a minimisation, updated between them): the energy has the load's potential ``-q·P``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..lattice import GRADIENT, HESSIAN, HESSIAN_CONVEX, assemble
from ..layout import free_node
from .records import LOAD_S, LOAD_X, LOAD_Y, SHIFT


@kernel(inline="always")
def penalty(gamma, kappa, eps):
    """``(ψ, ψ', ψ'')`` of the C² one-sided penalty at the shifted gap ``gamma`` (mm)."""
    if gamma >= 0.0:
        return 0.0, 0.0, 0.0
    if gamma > -eps:
        return (
            -kappa * gamma**3 / (6.0 * eps),
            -kappa * gamma * gamma / (2.0 * eps),
            (-kappa * gamma / eps),
        )
    return (
        kappa * (0.5 * gamma * gamma + 0.5 * eps * gamma + eps * eps / 6.0),
        kappa * (gamma + 0.5 * eps),
        kappa,
    )


@kernel
def segment_gap(pos, a, b, disk, dg, d2g):
    """Gap (mm) between the disk and the segment from node ``a`` to node ``b``.

    Fills ``dg`` (shape (4,)) with its gradient in ``(A_x, A_y, B_x, B_y)`` and ``d2g``
    (shape (4, 4), 1/mm) with its Hessian. Returns ``(gap, s, nx, ny)``: the position ``s`` in
    [0, 1] of the closest point along the segment and the unit normal from it to the centre.
    """
    ax_ = pos[a, 0]
    ay_ = pos[a, 1]
    ex = pos[b, 0] - ax_
    ey = pos[b, 1] - ay_
    wx = disk.cx - ax_
    wy = disk.cy - ay_
    l2 = ex * ex + ey * ey
    s = (wx * ex + wy * ey) / l2
    for i in range(4):
        for j in range(4):
            d2g[i, j] = 0.0
    reach = disk.radius + disk.offset
    if 0.0 < s < 1.0:
        ell = math.sqrt(l2)
        num = ex * wy - ey * wx
        dist = num / ell
        # ∇N and ∇L in (A_x, A_y, B_x, B_y); ∇²N is constant (N is bilinear in e and w).
        gn = (ey - wy, wx - ex, wy, -wx)
        ux = ex / ell
        uy = ey / ell
        gl = (-ux, -uy, ux, uy)
        hn = np.zeros((4, 4))
        hn[0, 3] = 1.0
        hn[3, 0] = 1.0
        hn[1, 2] = -1.0
        hn[2, 1] = -1.0
        # ∇²L: blocks ±(I - u uᵀ)/L
        pxx = (1.0 - ux * ux) / ell
        pxy = -ux * uy / ell
        pyy = (1.0 - uy * uy) / ell
        hl = np.empty((4, 4))
        for i in range(2):
            for j in range(2):
                sign = 1.0 if i == j else -1.0
                hl[2 * i, 2 * j] = sign * pxx
                hl[2 * i, 2 * j + 1] = sign * pxy
                hl[2 * i + 1, 2 * j] = sign * pxy
                hl[2 * i + 1, 2 * j + 1] = sign * pyy
        for i in range(4):
            dg[i] = gn[i] / ell - num * gl[i] / l2
        for i in range(4):
            for j in range(4):
                d2g[i, j] = (
                    hn[i, j] / ell
                    - (gn[i] * gl[j] + gl[i] * gn[j]) / l2
                    - num * hl[i, j] / l2
                    + 2.0 * num * gl[i] * gl[j] / (l2 * ell)
                )
        return dist - reach, s, -uy, ux
    # beyond an end: the distance to that node
    end = 0 if s <= 0.0 else 1
    px = pos[a, 0] if end == 0 else pos[b, 0]
    py = pos[a, 1] if end == 0 else pos[b, 1]
    rx = disk.cx - px
    ry = disk.cy - py
    r = math.sqrt(rx * rx + ry * ry)
    nx = rx / r
    ny = ry / r
    for i in range(4):
        dg[i] = 0.0
    dg[2 * end] = -nx
    dg[2 * end + 1] = -ny
    o = 2 * end
    d2g[o, o] = (1.0 - nx * nx) / r
    d2g[o, o + 1] = -nx * ny / r
    d2g[o + 1, o] = -nx * ny / r
    d2g[o + 1, o + 1] = (1.0 - ny * ny) / r
    return r - reach, 0.0 if end == 0 else 1.0, nx, ny


@kernel
def energy_with_contact(x, lat, disk, contact, kp, mode, ws):
    """Energy (N·mm) of one finger against the disk and, by ``mode``, its gradient and Hessian.

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        Free coordinates.
    lat : GraspLattice
    disk : Disk
    contact : ndarray of shape (N, N_CONTACT_COLS)
        Shifts (mm) and friction loads (N) per segment, held fixed here.
    kp : tuple of float
        ``(kappa, eps)``: the penalty's stiffness (N/mm) and smoothing width (mm).
    mode : int
        ``ENERGY``, ``GRADIENT``, ``HESSIAN`` or ``HESSIAN_CONVEX`` (the lattice's convexified
        Hessian plus the contact's Gauss-Newton part ``ψ'' ∇g ∇gᵀ``, positive semi-definite).
    ws : tuple
        From :func:`dpfexplore._kernels.grasp.equilibrium.workspace`; ``ws[1]`` and ``ws[2]``
        receive the gradient (N) and Hessian (N/mm), ``ws[0]`` the node positions.

    Returns
    -------
    total : float
        Lattice, penalty and friction-load energy (N·mm).
    lattice : float
        The lattice's part alone (N·mm).
    """
    pos, grad, hess, _, _, _, split, dg, d2g = ws[:9]
    kappa, eps = kp
    e_lattice = assemble(x, lat.unit_params, lat.h, pos, grad, hess, mode, split)
    total = e_lattice
    n_units = lat.unit_params.shape[0]
    for k in range(1, n_units + 1):
        a = 2 * k - 1
        b = 2 * k + 1
        fa = free_node(a)
        fb = free_node(b)
        # friction load: dead load at its material point
        qx = contact[k - 1, LOAD_X]
        qy = contact[k - 1, LOAD_Y]
        if qx != 0.0 or qy != 0.0:
            sq = contact[k - 1, LOAD_S]
            px = (1.0 - sq) * pos[a, 0] + sq * pos[b, 0]
            py = (1.0 - sq) * pos[a, 1] + sq * pos[b, 1]
            total -= qx * px + qy * py
            if mode >= GRADIENT:
                if fa >= 0:
                    grad[2 * fa] -= (1.0 - sq) * qx
                    grad[2 * fa + 1] -= (1.0 - sq) * qy
                if fb >= 0:
                    grad[2 * fb] -= sq * qx
                    grad[2 * fb + 1] -= sq * qy
        if fa < 0 and fb < 0:
            continue  # the clamped first segment: a constant, the base's reaction
        gap, _, _, _ = segment_gap(pos, a, b, disk, dg, d2g)
        psi, psi1, psi2 = penalty(gap - contact[k - 1, SHIFT], kappa, eps)
        if psi == 0.0 and psi1 == 0.0:
            continue
        total += psi
        if mode < GRADIENT:
            continue
        idx = (2 * fa, 2 * fa + 1, 2 * fb, 2 * fb + 1)
        for i in range(4):
            if idx[i] >= 0:
                grad[idx[i]] += psi1 * dg[i]
        if mode < HESSIAN:
            continue
        geometric = 0.0 if mode == HESSIAN_CONVEX else psi1
        for i in range(4):
            if idx[i] < 0:
                continue
            for j in range(4):
                if idx[j] >= 0:
                    hess[idx[i], idx[j]] += psi2 * dg[i] * dg[j] + geometric * d2g[i, j]
    return total, e_lattice
