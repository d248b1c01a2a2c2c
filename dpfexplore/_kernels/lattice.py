"""Energy, analytic gradient and analytic Hessian of the DPF spring lattice (MODEL.md §5).

One assembly routine, :func:`assemble`, serves every caller in the project (statics, stiffness,
dynamics, the SciPy baseline's cross-checks): it visits each spring once and adds its energy and,
on request, its gradient and Hessian in the free coordinates (see :mod:`.layout`).

Springs
    * two-node springs of energy ``f(ℓ)`` in their length ``ℓ``: posts and limiting-layer
      segments (linear, ``½ k (ℓ - s)²``) and domes (MODEL.md §4). Gradient ``f' e`` and Hessian
      ``f'' e eᵀ + (f'/ℓ)(I - e eᵀ)`` with ``e`` the unit vector.
    * torsional springs ``½ k_t δ²`` on the deviation ``δ = ϑ - π/2`` of the angle at a
      limiting-layer node. ``ϑ`` is the signed angle from the first arm to the second, written as
      the difference of the arms' polar angles, so its derivatives (``∇φ(v) = (-v_y, v_x)/|v|²``
      and the matching Hessian) are exact for every configuration, including arms that are
      parallel or anti-parallel (``ϑ`` near 0 or π), where the implementation's
      ``arccos``/``sin ϑ`` form divides by zero. The value is ``atan2(-v_a·v_b, v_a×v_b)``,
      whose branch cut lies at ``ϑ = -π/2``, opposite the rest angle. For every configuration
      with ``0 <= ϑ <= π`` it equals the implementation's unsigned angle.

Compiling. The springs' entry helpers (:func:`spring_nodes`, :func:`_dome_scalar`,
:func:`_scatter_pair`, :func:`_torsion`) are inlined into :func:`assemble` by Numba; what they
call (:func:`dome_law`, the 2x2 block and vector adders, the torsion's pair blocks) are functions
of their own, each compiled once, that LLVM inlines where they are called. Numba inlines a
function by running its front end again at each call site, and through each nested inline helper
again: the torsion's six pair blocks, each with its adders, at both of its call sites made
:func:`assemble` cost about three times as much to compile, for the same machine code.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel
from .layout import (
    COL_ALPHA,
    COL_D,
    COL_KB,
    COL_KLIM,
    COL_KPOST,
    COL_KT,
    COL_P,
    COL_PEN,
    COL_U_HI,
    COL_U_LO,
    free_node,
    n_free,
    n_nodes,
)

#: ``assemble`` modes. NumPy integers on purpose: Numba types a Python ``int`` constant passed
#: as an argument as a literal and compiles one copy of :func:`assemble` per mode (three in the
#: state search alone, about 5 s of compile time each, and every caller re-optimises all the
#: copies it links); ``int64`` constants give one compiled copy for every caller.
ENERGY = np.int64(0)
GRADIENT = np.int64(1)
HESSIAN = np.int64(2)
#: The Hessian with every spring's own curvature made non-negative (see :func:`assemble`): a
#: positive semi-definite model of the energy for steps where the true Hessian is indefinite.
HESSIAN_CONVEX = np.int64(3)

#: Indices into the ``split`` array filled by :func:`assemble`.
SPLIT_LINEAR = 0  # posts and limiting layer
SPLIT_DOME = 1
SPLIT_TORSION = 2
SPLIT_PENALTY = 3  # state-search steering only; zero for physical evaluations
N_SPLIT = 4


#: The two-node springs of a unit, in the order :func:`spring_nodes` numbers them.
SPRING_POST = 0  # D_k - L_k, the post closing unit k
SPRING_LAYER = 1  # L_{k-1} - L_k, the limiting-layer segment
SPRING_DOME = 2  # D_{k-1} - D_k, the dome


@kernel(inline="always")
def spring_nodes(k, spring, h, p):
    """Nodes ``(a, b)`` and rest length (mm) of two-node spring ``spring`` of unit ``k``.

    ``p`` is the unit's segment length and ``h`` the segment height (the post's rest length).
    """
    if spring == SPRING_POST:
        return 2 * k, 2 * k + 1, h
    if spring == SPRING_LAYER:
        return 2 * k + 1, 2 * k - 1, p
    return 2 * k, 2 * k - 2, p


@kernel
def unpack_nodes(x, unit_params, h, pos):
    """Fill ``pos`` (shape ``(2N + 2, 2)``, mm) from the free coordinates ``x`` and the clamps."""
    n_units = unit_params.shape[0]
    pos[0, 0] = 0.0
    pos[0, 1] = 0.0
    pos[1, 0] = 0.0
    pos[1, 1] = h
    pos[3, 0] = unit_params[0, COL_P]
    pos[3, 1] = h
    pos[2, 0] = x[0]
    pos[2, 1] = x[1]
    for node in range(4, n_nodes(n_units)):
        f = node - 3
        pos[node, 0] = x[2 * f]
        pos[node, 1] = x[2 * f + 1]


@kernel
def rest_nodes(unit_params, h, pos):
    """Fill ``pos`` with the stress-free flat finger (posts at ``X_k = Σ p_j``)."""
    n_units = unit_params.shape[0]
    x_post = 0.0
    for k in range(n_units + 1):
        if k > 0:
            x_post += unit_params[k - 1, COL_P]
        pos[2 * k, 0] = x_post
        pos[2 * k, 1] = 0.0
        pos[2 * k + 1, 0] = x_post
        pos[2 * k + 1, 1] = h


@kernel
def pack_free(pos, n_units, x):
    """Inverse of :func:`unpack_nodes`: copy the free nodes of ``pos`` into ``x``."""
    x[0] = pos[2, 0]
    x[1] = pos[2, 1]
    for node in range(4, n_nodes(n_units)):
        f = node - 3
        x[2 * f] = pos[node, 0]
        x[2 * f + 1] = pos[node, 1]


@kernel
def dome_law(x_bar, row):
    """Isolated dome's energy ``f`` and its first two derivatives in the extension ``x̄``.

    MODEL.md §4, with ``k_b``, ``α`` and ``d`` from the unit's ``row`` of the kernel table;
    no penalty (:func:`_dome_scalar` adds it). Returns ``(f, f', f'')``.
    """
    kb = row[COL_KB]
    one_minus_alpha = 1.0 - row[COL_ALPHA]
    d = row[COL_D]
    u = x_bar / d
    f = 0.5 * kb * x_bar * x_bar * (1.0 + one_minus_alpha * (u * u - 2.0 * u))
    f1 = kb * x_bar * (1.0 + one_minus_alpha * (2.0 * u * u - 3.0 * u))
    f2 = kb * (1.0 + 6.0 * one_minus_alpha * (u * u - u))
    return f, f1, f2


@kernel(inline="always")
def _dome_scalar(x_bar, row):
    """:func:`dome_law` plus the steering penalty of :data:`.layout.COL_PEN`, if any.

    Returns ``(f, f', f'', penalty_energy)``.
    """
    f, f1, f2 = dome_law(x_bar, row)
    d = row[COL_D]
    pen_energy = 0.0
    pen = row[COL_PEN]
    if pen > 0.0:
        lo = row[COL_U_LO] * d
        hi = row[COL_U_HI] * d
        if x_bar < lo:
            gap = lo - x_bar
            pen_energy = 0.5 * pen * gap * gap
            f1 -= pen * gap
            f2 += pen
        elif x_bar > hi:
            gap = x_bar - hi
            pen_energy = 0.5 * pen * gap * gap
            f1 += pen * gap
            f2 += pen
    return f, f1, f2, pen_energy


@kernel
def _add_block(hess, fi, fj, m00, m01, m10, m11):
    """Add a 2x2 block at free nodes ``(fi, fj)`` (skipped when either is clamped)."""
    if fi < 0 or fj < 0:
        return
    i = 2 * fi
    j = 2 * fj
    hess[i, j] += m00
    hess[i, j + 1] += m01
    hess[i + 1, j] += m10
    hess[i + 1, j + 1] += m11


@kernel
def _add_vector(grad, fi, vx, vy):
    if fi >= 0:
        grad[2 * fi] += vx
        grad[2 * fi + 1] += vy


@kernel(inline="always")
def _scatter_pair(a, b, e, ell, slopes, mode, grad, hess):
    """Add gradient/Hessian of a two-node spring with energy ``f(ℓ)``.

    ``e = (x_a - x_b)/ℓ`` as ``(ex, ey)``; ``slopes``: ``(f', f'')`` at ``ℓ`` (N, N/mm).
    """
    ex, ey = e
    f1, f2 = slopes
    fa = free_node(a)
    fb = free_node(b)
    _add_vector(grad, fa, f1 * ex, f1 * ey)
    _add_vector(grad, fb, -f1 * ex, -f1 * ey)
    if mode < HESSIAN:
        return
    q = f1 / ell
    if mode == HESSIAN_CONVEX:  # the spring's curvatures along and across e, made non-negative
        f2 = abs(f2)
        q = abs(q)
    kxx = f2 * ex * ex + q * (1.0 - ex * ex)
    kxy = (f2 - q) * ex * ey
    kyy = f2 * ey * ey + q * (1.0 - ey * ey)
    _add_block(hess, fa, fa, kxx, kxy, kxy, kyy)
    _add_block(hess, fb, fb, kxx, kxy, kxy, kyy)
    _add_block(hess, fa, fb, -kxx, -kxy, -kxy, -kyy)
    _add_block(hess, fb, fa, -kxx, -kxy, -kxy, -kyy)


@kernel(inline="always")
def _torsion(pos, a, c, b, kt, mode, grad, hess):
    """Torsional spring on the angle ``a-c-b`` (arms ``c→a`` and ``c→b``); returns its energy."""
    vax = pos[a, 0] - pos[c, 0]
    vay = pos[a, 1] - pos[c, 1]
    vbx = pos[b, 0] - pos[c, 0]
    vby = pos[b, 1] - pos[c, 1]
    cross = vax * vby - vay * vbx
    dot = vax * vbx + vay * vby
    delta = math.atan2(-dot, cross)
    energy = 0.5 * kt * delta * delta
    if mode == 0:
        return energy
    ra2 = vax * vax + vay * vay
    rb2 = vbx * vbx + vby * vby
    # ∇φ of each arm; ∂δ/∂x_a = -ga, ∂δ/∂x_c = ga - gb, ∂δ/∂x_b = gb.
    gax = -vay / ra2
    gay = vax / ra2
    gbx = -vby / rb2
    gby = vbx / rb2
    g0x, g0y = -gax, -gay
    g1x, g1y = gax - gbx, gay - gby
    g2x, g2y = gbx, gby
    fa = free_node(a)
    fc = free_node(c)
    fb = free_node(b)
    s = kt * delta
    _add_vector(grad, fa, s * g0x, s * g0y)
    _add_vector(grad, fc, s * g1x, s * g1y)
    _add_vector(grad, fb, s * g2x, s * g2y)
    if mode < HESSIAN:
        return energy
    # Hessian of φ(v): [[2 vx vy, vy² - vx²], [vy² - vx², -2 vx vy]] / |v|⁴.
    ra4 = ra2 * ra2
    rb4 = rb2 * rb2
    ha00 = 2.0 * vax * vay / ra4
    ha01 = (vay * vay - vax * vax) / ra4
    hb00 = 2.0 * vbx * vby / rb4
    hb01 = (vby * vby - vbx * vbx) / rb4
    # Blocks of ∇²δ: aa = -Ha, ac = Ha, cc = Hb - Ha, cb = -Hb, bb = Hb, ab = 0.
    # Each Hφ is symmetric with H11 = -H00, so two numbers describe it.
    k = kt
    if mode == HESSIAN_CONVEX:  # Gauss-Newton: keep k ∇δ ∇δᵀ, drop the indefinite k δ ∇²δ
        s = 0.0
    g0 = (g0x, g0y)
    g1 = (g1x, g1y)
    g2 = (g2x, g2y)
    _pair_block(hess, fa, k, g0, s, (-ha00, -ha01))
    _pair_block(hess, fc, k, g1, s, (hb00 - ha00, hb01 - ha01))
    _pair_block(hess, fb, k, g2, s, (hb00, hb01))
    _pair_block_sym(hess, fa, fc, k, g0, g1, s, (ha00, ha01))
    _pair_block_sym(hess, fc, fb, k, g1, g2, s, (-hb00, -hb01))
    _pair_block_sym(hess, fa, fb, k, g0, g2, s, (0.0, 0.0))
    return energy


@kernel
def _pair_block(hess, fi, k, g, s, b):
    """Add the diagonal block ``k g gᵀ + s B``, ``B = [[h00, h01], [h01, -h00]]``.

    ``g = (gx, gy)``, ``b = (h00, h01)``. The off-diagonal entry is computed once so that the
    Hessian is exactly symmetric.
    """
    gx, gy = g
    h00, h01 = b
    m01 = k * gx * gy + s * h01
    _add_block(hess, fi, fi, k * gx * gx + s * h00, m01, m01, k * gy * gy - s * h00)


@kernel
def _pair_block_sym(hess, fi, fj, k, gi, gj, s, b):
    """Add the ``(i, j)`` block of :func:`_pair_block` and its transpose at ``(j, i)``.

    ``gi = (gix, giy)``, ``gj = (gjx, gjy)``, ``b = (h00, h01)``.
    """
    gix, giy = gi
    gjx, gjy = gj
    h00, h01 = b
    m00 = k * gix * gjx + s * h00
    m01 = k * gix * gjy + s * h01
    m10 = k * giy * gjx + s * h01
    m11 = k * giy * gjy - s * h00
    _add_block(hess, fi, fj, m00, m01, m10, m11)
    _add_block(hess, fj, fi, m00, m10, m01, m11)


@kernel
def assemble(x, unit_params, h, pos, grad, hess, mode, split):
    """Lattice energy (N·mm) and, by ``mode``, its gradient (N) and Hessian (N/mm).

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        Free coordinates (see :mod:`.layout`).
    unit_params : ndarray of shape (N, N_COLS)
        Per-unit constants.
    h : float, mm
        Segment height (post rest length).
    pos : ndarray of shape (2N + 2, 2)
        Scratch for node positions (filled here).
    grad : ndarray of shape (4N - 2,)
        Filled when ``mode >= GRADIENT``.
    hess : ndarray of shape (4N - 2, 4N - 2)
        Filled when ``mode >= HESSIAN``.
    mode : int
        ``ENERGY``, ``GRADIENT``, ``HESSIAN`` or ``HESSIAN_CONVEX``. The last assembles, in
        place of the Hessian, the sum of every spring's Hessian made positive semi-definite:
        a two-node spring's curvatures along and across its axis (``f''`` and ``f'/ℓ``) by
        their absolute values (a dome on its unstable branch, a compressed spring), a torsional
        spring's by its Gauss-Newton part ``k_t ∇δ ∇δᵀ`` (projected Newton on element
        Hessians, as in quasi-static finite elements).
    split : ndarray of shape (N_SPLIT,)
        Energy by spring type (linear, dome, torsion, penalty), always filled.

    Returns
    -------
    float
        Total energy including any steering penalty.
    """
    n_units = unit_params.shape[0]
    unpack_nodes(x, unit_params, h, pos)
    nf = n_free(n_units)
    if mode >= GRADIENT:
        for i in range(nf):
            grad[i] = 0.0
    if mode >= HESSIAN:
        for i in range(nf):
            for j in range(nf):
                hess[i, j] = 0.0
    e_linear = 0.0
    e_dome = 0.0
    e_torsion = 0.0
    e_penalty = 0.0
    for k in range(1, n_units + 1):
        row = unit_params[k - 1]
        p = row[COL_P]
        # Two-node springs of unit k: post D_k-L_k, layer L_{k-1}-L_k, dome D_{k-1}-D_k.
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            stiff = row[COL_KPOST] if spring == SPRING_POST else row[COL_KLIM]
            if free_node(a) < 0 and free_node(b) < 0:
                continue  # both ends clamped (the first unit's layer): constant zero energy
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            ell = math.sqrt(dx * dx + dy * dy)
            stretch = ell - rest
            if spring == SPRING_DOME:
                f, f1, f2, pen = _dome_scalar(stretch, row)
                e_dome += f
                e_penalty += pen
            else:
                f1 = stiff * stretch
                f2 = stiff
                e_linear += 0.5 * stiff * stretch * stretch
            if mode >= GRADIENT:
                _scatter_pair(a, b, (dx / ell, dy / ell), ell, (f1, f2), mode, grad, hess)
        # Torsion at L_k: angle L_{k-1}-L_k-D_k, and D_k-L_k-L_{k+1} except at the tip.
        kt = row[COL_KT]
        e_torsion += _torsion(pos, 2 * k - 1, 2 * k + 1, 2 * k, kt, mode, grad, hess)
        if k < n_units:
            e_torsion += _torsion(pos, 2 * k, 2 * k + 1, 2 * k + 3, kt, mode, grad, hess)
    split[SPLIT_LINEAR] = e_linear
    split[SPLIT_DOME] = e_dome
    split[SPLIT_TORSION] = e_torsion
    split[SPLIT_PENALTY] = e_penalty
    return e_linear + e_dome + e_torsion + e_penalty


@kernel
def lattice_energy(x, unit_params, h):
    """Total lattice energy (N·mm) at free coordinates ``x`` (allocating convenience wrapper)."""
    n_units = unit_params.shape[0]
    pos = np.empty((n_nodes(n_units), 2))
    dummy_g = np.empty(0)
    dummy_h = np.empty((0, 0))
    split = np.empty(4)
    return assemble(x, unit_params, h, pos, dummy_g, dummy_h, ENERGY, split)


@kernel
def lattice_energy_split(x, unit_params, h, split):
    """Total energy (N·mm); ``split`` receives linear, dome, torsion and penalty parts."""
    n_units = unit_params.shape[0]
    pos = np.empty((n_nodes(n_units), 2))
    return assemble(x, unit_params, h, pos, np.empty(0), np.empty((0, 0)), ENERGY, split)


@kernel
def lattice_gradient(x, unit_params, h, grad):
    """Energy (N·mm); ``grad`` (shape ``(4N - 2,)``, N) receives the analytic gradient."""
    n_units = unit_params.shape[0]
    pos = np.empty((n_nodes(n_units), 2))
    split = np.empty(4)
    return assemble(x, unit_params, h, pos, grad, np.empty((0, 0)), GRADIENT, split)


@kernel
def lattice_hessian(x, unit_params, h, grad, hess):
    """Energy (N·mm); fills the analytic gradient (N) and Hessian (N/mm)."""
    n_units = unit_params.shape[0]
    pos = np.empty((n_nodes(n_units), 2))
    split = np.empty(4)
    return assemble(x, unit_params, h, pos, grad, hess, HESSIAN, split)


@kernel
def dome_extensions(x, unit_params, h, pos, u):
    """Fill ``u`` (shape ``(N,)``) with each dome's extension over its reach, ``x̄/d``."""
    n_units = unit_params.shape[0]
    unpack_nodes(x, unit_params, h, pos)
    for k in range(1, n_units + 1):
        dx = pos[2 * k, 0] - pos[2 * k - 2, 0]
        dy = pos[2 * k, 1] - pos[2 * k - 2, 1]
        u[k - 1] = (math.sqrt(dx * dx + dy * dy) - unit_params[k - 1, COL_P]) / unit_params[
            k - 1, COL_D
        ]
