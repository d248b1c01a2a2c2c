"""Energy, gradient and exact Hessian of a discretised axisymmetric shell (Numba).

The meridian of a shell of revolution is a polygon of ``N`` straight segments with nodes
``(r_k, z_k)``, ``k = 0..N``: node 0 on the axis (the apex), node ``N`` on the pinned edge. The
strain measures are those of Reissner's exact axisymmetric shell theory (Reissner 1950; Wan;
Libai & Simmonds), shear-rigid, per unit reference length:

* meridional stretch of segment ``j``: ``ε_s = ℓ_j / ℓ0_j - 1``;
* hoop stretch at the segment's midpoint: ``ε_θ = (r_j + r_{j+1}) / (r0_j + r0_{j+1}) - 1``;
* meridional bending at node ``i``: ``κ_s = (β_i - β0_i) / s0_i``, ``β_i`` the turning angle
  between segments ``i-1`` and ``i`` and ``s0_i`` the mean of their reference lengths;
* hoop bending at node ``i``: ``κ_θ = (sin α_i - sin α0_i) / r0_i``, ``α_i`` the mean of the
  two segments' slope angles (``a = atan2(-Δz, Δr)``, positive on the undeformed cap).

Energy ``Π = Σ_j wm_j C/2 (ε_s² + 2ν ε_s ε_θ + ε_θ²) + Σ_i A_i D/2 (κ_s² + 2ν κ_s κ_θ + κ_θ²)``
with ``C = E t / (1 - ν²)``, ``D = E t³ / (12 (1 - ν²))``, ``wm_j`` the frustum area of segment
``j`` and ``A_i`` the area between the midpoints of the segments next to node ``i`` (the
reference polygon's own areas, so the discrete reference state is exactly strain-free).

Apex (node 0): on the axis (``r = 0``), its tangent horizontal by symmetry: a mirrored ghost
segment gives ``κ_s = 2 (a_0 - a0_0) / ℓ0_0`` and, in the limit ``r → 0``, ``κ_θ = κ_s``.
Edge (node ``N``): position fixed, rotation free; its area carries the hoop bending at zero
meridional moment, ``D/2 (1 - ν²) κ_θ²`` (``κ_s`` eliminated by ``M_s = 0``). An elastic edge
adds ``k_edge/2 (a_{N-1} - a0_{N-1})²``, a rotational spring (N·mm/rad, the whole ring) on the
last segment's slope: 0 is the pinned edge, a large value a clamped one.

Unknowns ``y`` (length ``m = 2N - 1``): ``y[0] = δ``, the apex travel (``z_0 = z0_0 - δ``), then
``(r_k, z_k)`` of nodes ``1..N-1`` at ``y[2k-1], y[2k]``. The Hessian is banded (a node's bending
couples it to the nodes two away): half-bandwidth :data:`BAND` = 5, stored as
``band[i, BAND + j - i]`` (both triangles).

The reference polygon and the material reach the kernels as one
:data:`~.shell.records.ShellGeometry` record ``geom``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from .records import AnglePartials

#: Half-bandwidth of the Hessian in the unknowns ``y``.
BAND = 5


@kernel
def n_unknowns(geom):
    """Length of ``y``: the apex travel and ``(r, z)`` of the free nodes."""
    return 2 * (geom.r0.shape[0] - 1) - 1


@kernel
def nodes(y, geom, r, z):
    """Fill the node coordinates ``r, z`` (mm, ``N + 1``) of the unknowns ``y``."""
    n = geom.r0.shape[0] - 1
    r[0] = 0.0
    z[0] = geom.z0[0] - y[0]
    for k in range(1, n):
        r[k] = y[2 * k - 1]
        z[k] = y[2 * k]
    r[n] = geom.r0[n]
    z[n] = geom.z0[n]


@kernel(inline="always")
def _dof(k, c, n):
    """Unknown index of coordinate ``c`` (0: r, 1: z) of node ``k``, or -1 if prescribed."""
    if k == 0:
        return 0 if c == 1 else -1
    if k == n:
        return -1
    return 2 * k - 1 + c


@kernel(inline="always")
def _sign(k):
    # z_0 = z0_0 - δ: the apex's z enters through -δ.
    return -1.0 if k == 0 else 1.0


@kernel
def _scatter(first, nloc, gl, hl, n, grad, band, want):
    """Add a local gradient/Hessian over nodes ``first .. first + nloc - 1`` (2 coords each)."""
    for a in range(2 * nloc):
        ka = first + a // 2
        ia = _dof(ka, a % 2, n)
        if ia < 0:
            continue
        sa = _sign(ka) if a % 2 == 1 else 1.0
        if want >= 1:
            grad[ia] += sa * gl[a]
        if want >= 2:
            for b in range(2 * nloc):
                kb = first + b // 2
                ib = _dof(kb, b % 2, n)
                if ib < 0:
                    continue
                sb = _sign(kb) if b % 2 == 1 else 1.0
                band[ia, BAND + ib - ia] += sa * sb * hl[a, b]


@kernel
def segment_angles(r, z, ang, ja, ha):
    """Slope angle ``a = atan2(-Δz, Δr)`` of every segment, its gradient and Hessian in Δ.

    ``ja[j] = (∂a/∂Δr, ∂a/∂Δz)``; ``ha[j] = (∂²a/∂Δr², ∂²a/∂Δr∂Δz, ∂²a/∂Δz²)``.
    """
    for j in range(ang.shape[0]):
        x = r[j + 1] - r[j]
        w = z[j + 1] - z[j]
        rho2 = x * x + w * w
        ang[j] = math.atan2(-w, x)
        ja[j, 0] = w / rho2
        ja[j, 1] = -x / rho2
        rho4 = rho2 * rho2
        ha[j, 0] = -2.0 * x * w / rho4
        ha[j, 1] = (x * x - w * w) / rho4
        ha[j, 2] = 2.0 * x * w / rho4


@kernel
def assemble(y, geom, grad, band, want):
    """Energy of ``y``; with ``want >= 1`` the gradient, ``>= 2`` the Hessian band, added.

    ``grad`` (``m``) and ``band`` (``m × (2 BAND + 1)``) are zeroed here when requested.
    Returns ``(membrane, bending)`` strain energy, N·mm.
    """
    n = geom.r0.shape[0] - 1
    C = geom.C
    D = geom.D
    nu = geom.nu
    if want >= 1:
        grad[:] = 0.0
    if want >= 2:
        band[:, :] = 0.0
    r = np.empty(n + 1)
    z = np.empty(n + 1)
    nodes(y, geom, r, z)
    ang = np.empty(n)
    ja = np.empty((n, 2))
    ha = np.empty((n, 3))
    segment_angles(r, z, ang, ja, ha)
    gl = np.zeros(6)
    hl = np.zeros((6, 6))

    # Membrane, per segment: local coordinates (r_j, z_j, r_{j+1}, z_{j+1}).
    membrane = 0.0
    for j in range(n):
        dr = r[j + 1] - r[j]
        dz = z[j + 1] - z[j]
        ell = math.sqrt(dr * dr + dz * dz)
        l0 = geom.l0[j]
        es = ell / l0 - 1.0
        q = 1.0 / (2.0 * geom.rm0[j])
        et = (r[j] + r[j + 1]) * q - 1.0
        w = geom.wm[j] * C
        membrane += 0.5 * w * (es * es + 2.0 * nu * es * et + et * et)
        if want == 0:
            continue
        ws = w * (es + nu * et)
        wt = w * (et + nu * es)
        er = dr / ell
        ez = dz / ell
        gs0 = -er / l0
        gs1 = -ez / l0
        gl[0] = ws * gs0 + wt * q
        gl[1] = ws * gs1
        gl[2] = -ws * gs0 + wt * q
        gl[3] = -ws * gs1
        if want >= 2:
            # ∂ε_s = (-e, e)/ℓ0, ∂ε_θ = (q, 0, q, 0);
            # ∂²ε_s = [[P, -P], [-P, P]] with P = (I - eeᵀ)/(ℓ ℓ0)
            gs = (gs0, gs1, -gs0, -gs1)
            gt = (q, 0.0, q, 0.0)
            for a in range(4):
                for b in range(4):
                    hl[a, b] = w * (
                        gs[a] * gs[b] + nu * (gs[a] * gt[b] + gt[a] * gs[b]) + gt[a] * gt[b]
                    )
            f = ws / (ell * l0)
            p00 = f * (1.0 - er * er)
            p01 = -f * er * ez
            p11 = f * (1.0 - ez * ez)
            for s in range(2):
                for u in range(2):
                    sg = 1.0 if s == u else -1.0
                    hl[2 * s, 2 * u] += sg * p00
                    hl[2 * s, 2 * u + 1] += sg * p01
                    hl[2 * s + 1, 2 * u] += sg * p01
                    hl[2 * s + 1, 2 * u + 1] += sg * p11
        _scatter(j, 2, gl, hl, n, grad, band, want)

    # Bending at the apex: depends on a_0 alone (local coordinates of nodes 0, 1).
    bending = 0.0
    k0 = 2.0 / geom.l0[0]
    kap = k0 * (ang[0] - geom.a0[0])
    wa = geom.area[0] * D * (1.0 + nu)
    bending += wa * kap * kap
    if want >= 1:
        u1 = 2.0 * wa * kap * k0
        u2 = 2.0 * wa * k0 * k0
        _angle_term(0, u1, u2, ja, ha, gl, hl, want)
        _scatter(0, 2, gl, hl, n, grad, band, want)

    # Bending at interior nodes i = 1..n-1: segments i-1 (u) and i (v), nodes i-1, i, i+1.
    for i in range(1, n):
        beta = ang[i] - ang[i - 1]
        if beta > math.pi:
            beta -= 2.0 * math.pi
        elif beta < -math.pi:
            beta += 2.0 * math.pi
        alpha = ang[i - 1] + 0.5 * beta
        sa = math.sin(alpha)
        ca = math.cos(alpha)
        s0 = geom.s0[i]
        rr = geom.r0[i]
        ks = (beta - geom.beta0[i]) / s0
        kt = (sa - geom.sa0[i]) / rr
        w = geom.area[i] * D
        bending += 0.5 * w * (ks * ks + 2.0 * nu * ks * kt + kt * kt)
        if want == 0:
            continue
        ms = w * (ks + nu * kt)
        mt = w * (kt + nu * ks)
        dks_u = -1.0 / s0
        dks_v = 1.0 / s0
        dkt = 0.5 * ca / rr
        ddkt = -0.25 * sa / rr
        uu = ms * dks_u + mt * dkt
        uv = ms * dks_v + mt * dkt
        huu = w * (dks_u * dks_u + 2.0 * nu * dks_u * dkt + dkt * dkt) + mt * ddkt
        hvv = w * (dks_v * dks_v + 2.0 * nu * dks_v * dkt + dkt * dkt) + mt * ddkt
        huv = w * (dks_u * dks_v + nu * (dks_u + dks_v) * dkt + dkt * dkt) + mt * ddkt
        _pair_term(i - 1, AnglePartials(uu, uv, huu, huv, hvv), ja, ha, gl, hl, want)
        _scatter(i - 1, 3, gl, hl, n, grad, band, want)

    # Bending at the edge: hoop curvature from the last segment's slope, M_s = 0; an elastic
    # edge (k_edge > 0) adds a rotational spring on the last segment's turning.
    rr = geom.r0[n]
    sa = math.sin(ang[n - 1])
    ca = math.cos(ang[n - 1])
    kt = (sa - math.sin(geom.a0[n - 1])) / rr
    w = geom.area[n] * D * (1.0 - nu * nu)
    bending += 0.5 * w * kt * kt
    kr = geom.k_edge
    turn = ang[n - 1] - geom.a0[n - 1]
    if kr != 0.0:
        bending += 0.5 * kr * turn * turn
    if want >= 1:
        u1 = w * kt * ca / rr
        u2 = w * (ca * ca / (rr * rr) - kt * sa / rr)
        if kr != 0.0:
            u1 += kr * turn
            u2 += kr
        _angle_term(n - 1, u1, u2, ja, ha, gl, hl, want)
        _scatter(n - 1, 2, gl, hl, n, grad, band, want)
    return membrane, bending


@kernel(inline="always")
def _angle_term(j, u1, u2, ja, ha, gl, hl, want):
    """Local gradient/Hessian (nodes j, j+1) of ``U(a_j)`` with ``U' = u1``, ``U'' = u2``."""
    g = (-ja[j, 0], -ja[j, 1], ja[j, 0], ja[j, 1])
    for a in range(4):
        gl[a] = u1 * g[a]
    if want >= 2:
        h00 = ha[j, 0]
        h01 = ha[j, 1]
        h11 = ha[j, 2]
        for a in range(4):
            for b in range(4):
                hl[a, b] = u2 * g[a] * g[b]
        for s in range(2):
            for v in range(2):
                sg = u1 if s == v else -u1
                hl[2 * s, 2 * v] += sg * h00
                hl[2 * s, 2 * v + 1] += sg * h01
                hl[2 * s + 1, 2 * v] += sg * h01
                hl[2 * s + 1, 2 * v + 1] += sg * h11


@kernel(inline="always")
def _pair_term(j, partials, ja, ha, gl, hl, want):
    """Local gradient/Hessian (nodes j..j+2) of ``U(a_j, a_{j+1})`` of its ``partials``."""
    uu, uv, huu, huv, hvv = partials
    # ∂a_j over the 6 local coordinates, and ∂a_{j+1}.
    gu = (-ja[j, 0], -ja[j, 1], ja[j, 0], ja[j, 1], 0.0, 0.0)
    gv = (0.0, 0.0, -ja[j + 1, 0], -ja[j + 1, 1], ja[j + 1, 0], ja[j + 1, 1])
    for a in range(6):
        gl[a] = uu * gu[a] + uv * gv[a]
    if want >= 2:
        for a in range(6):
            for b in range(6):
                hl[a, b] = (
                    huu * gu[a] * gu[b]
                    + huv * (gu[a] * gv[b] + gv[a] * gu[b])
                    + hvv * gv[a] * gv[b]
                )
        for off, seg, coef in ((0, j, uu), (2, j + 1, uv)):
            h00 = coef * ha[seg, 0]
            h01 = coef * ha[seg, 1]
            h11 = coef * ha[seg, 2]
            for s in range(2):
                for v in range(2):
                    sg = 1.0 if s == v else -1.0
                    hl[off + 2 * s, off + 2 * v] += sg * h00
                    hl[off + 2 * s, off + 2 * v + 1] += sg * h01
                    hl[off + 2 * s + 1, off + 2 * v] += sg * h01
                    hl[off + 2 * s + 1, off + 2 * v + 1] += sg * h11
