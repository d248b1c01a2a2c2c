"""Design sensitivities of a stable state: exact derivatives of its outputs in the design.

At a minimum ``x*`` of the lattice energy ``E(x, θ)`` the free gradient vanishes,
``g(x*(θ), θ) = 0``; where the Hessian ``H = ∂g/∂x`` is positive definite the implicit function
theorem gives ``dx*/dθ = -H⁻¹ ∂g/∂θ``. The parameters ``θ`` are every ``H_k``, ``U_L_k``,
``U_sep_k``, ``t``, ``t_lim`` and ``E``; they enter the energy through the per-unit constants
``p, k_b, α, d, k_lim, k_post, k_t`` and the segment height ``h`` (MODEL.md §3), whose derivatives
come from :mod:`.tables.design_tables` (``dtab``), and through the clamped nodes ``L_0 = (0, h)``
and ``L_1 = (p_1, h)``.

Tangent assembly
    ``∂g/∂θ``, ``∂E/∂θ`` and ``∂(rᵀ H r)/∂θ`` (for the stiffness) are assembled in forward mode
    for one parameter at a time, at fixed free coordinates, moving only the constants and the
    clamped nodes. A two-node spring of energy ``f(x̄; c)``, ``x̄ = ℓ - s``, ``ℓ = |x_a - x_b|``,
    ``e = (x_a - x_b)/ℓ``, with end motion ``δd`` and rest-length change ``δs``:
    ``δℓ = e·δd``, ``δx̄ = δℓ - δs``, ``δf' = f'' δx̄ + ∂f'/∂c·δc``, ``δe = (δd - e δℓ)/ℓ``, and
    the gradient ``f' e`` at ``a`` (``-f' e`` at ``b``) changes by ``δf' e + f' δe``. A torsional
    spring ``½ k_t δ²`` (:func:`.lattice._torsion`) changes its gradient ``k_t δ ∇δ`` by
    ``δk_t δ ∇δ + k_t δδ ∇δ + k_t δ δ(∇δ)`` with ``δ(∇φ) = Hφ δv``. A unit's parameters touch
    only that unit's springs, and ``p_1`` also the springs at ``L_1`` (unit 2's first layer
    segment and torsion), so each per-unit parameter costs O(1) springs.

Outputs (columns of :data:`N_SENS` rows)
    * tip ``L_N``: rows of ``dx*/dθ`` (for N = 1 the tip is the clamped ``L_1``: ``(dp_1, dh)``);
    * bend angle, the heading of the last layer segment ``Δ = L_N - L_{N-1}``:
      ``(Δ_x dΔ_y - Δ_y dΔ_x)/|Δ|²``; curvature = bend / layer length, with the length's
      derivative ``Σ e_k·(dL_k - dL_{k-1})``;
    * energy, by the envelope theorem ``dE*/dθ = ∂E/∂θ + g·dx*/dθ`` (``g ≈ 0``);
    * tip stiffness ``K = 1/(nᵀH⁻¹n)``, ``r = H⁻¹n``:
      ``dK/dθ = -K² (2 dn·r - rᵀ (dH/dθ) r)`` with ``rᵀ(dH/dθ)r = ∂(rᵀHr)/∂θ + w·dx*/dθ`` and
      ``w = ∇_x(rᵀ H(x) r)`` at fixed ``r``, the third-derivative contraction, computed exactly
      spring by spring (:func:`third_derivative_contraction`). For N = 1 the stiffness is
      ``inf`` and its derivatives are NaN: there is no finite value to differentiate.
    * ``E``: every stiffness is proportional to ``E`` and nothing else depends on it, so
      ``dx*/dE = 0`` exactly, ``d(energy)/dE = energy/E`` and ``d(stiffness)/dE = K/E``.

At a unit whose reach ``d`` is clamped (``no_contact``) the derivatives of ``d`` are 0 (the
branch in use; see :func:`dpfexplore.model.constants.constant_derivatives`). The steering
penalty of the state search is not differentiated: the tables must be physical (``COL_PEN`` 0).

The Hessian and its block Cholesky factor are assembled again at the returned shape (about a
microsecond at N = 5, a seventh of the sensitivities' cost) rather than read from the state
search's workspace, so that the sensitivities depend on the returned shape alone, not on what
the search leaves in its scratch arrays. One factorisation then serves all ``3N + 2`` solves.
"""

from __future__ import annotations

import math

import numpy as np

from ...model.domain import MAX_UNITS
from .._jit import kernel
from ..lattice import (
    HESSIAN,
    N_SPLIT,
    SPRING_DOME,
    SPRING_POST,
    assemble,
    dome_law,
    spring_nodes,
)
from ..layout import (
    COL_ALPHA,
    COL_D,
    COL_KB,
    COL_KLIM,
    COL_KPOST,
    COL_KT,
    COL_P,
    NODE_L0,
    NODE_L1,
    free_node,
    n_free,
    n_nodes,
)
from ..linalg.cholesky import cholesky, cholesky_solve
from ..records import Angle, Lattice, TangentParameter, TorsionArms
from ..statics.states import layer_bend, tip_stiffness
from ..tables.design_tables import DC_H, DP_T, N_DPARAM

# Rows of the sensitivity output.
SENS_TIP_X = 0
SENS_TIP_Y = 1
SENS_BEND = 2
SENS_CURVATURE = 3
SENS_ENERGY = 4
SENS_STIFFNESS = 5
N_SENS = 6


@kernel(inline="always")
def n_parameters(stride):
    """Columns of a sensitivity table laid out with ``stride`` columns per per-unit kind."""
    return 3 * stride + 3


@kernel(inline="always")
def parameter_column(kind, unit, stride):
    """Column of parameter ``kind`` (``DP_*``, or ``N_DPARAM`` for ``E``) of ``unit`` (1-based).

    Per-unit kinds occupy ``stride`` columns each (``H_1..``, ``U_L_1..``, ``U_sep_1..``), then
    come ``t``, ``t_lim`` and ``E``.
    """
    if kind < DP_T:
        return kind * stride + unit - 1
    return 3 * stride + kind - DP_T


@kernel
def workspace():
    """Scratch for :func:`design_sensitivities`, sized for ``MAX_UNITS`` units.

    ``(pos, grad, hess, low, r, w, dg, dx, split)``.
    """
    nf = n_free(MAX_UNITS)
    return (
        np.empty((n_nodes(MAX_UNITS), 2)),
        np.empty(nf),
        np.empty((nf, nf)),
        np.empty((nf, nf)),
        np.empty(nf),
        np.empty(nf),
        np.empty(nf),
        np.empty(nf),
        np.empty(N_SPLIT),
    )


@kernel(inline="always")
def _clamp_motion(node, dp1, dh):
    """Motion of a node at fixed free coordinates: ``L_0 = (0, h)``, ``L_1 = (p_1, h)``."""
    if node == NODE_L0:
        return 0.0, dh
    if node == NODE_L1:
        return dp1, dh
    return 0.0, 0.0


@kernel(inline="always")
def _node_vector(v, node):
    """Entries of free vector ``v`` at ``node`` (0 at clamped nodes)."""
    f = free_node(node)
    if f < 0:
        return 0.0, 0.0
    return v[2 * f], v[2 * f + 1]


@kernel(inline="always")
def _add(v, node, ax, ay):
    f = free_node(node)
    if f >= 0:
        v[2 * f] += ax
        v[2 * f + 1] += ay


@kernel(inline="always")
def _pair_scalars(spring, x_bar, row):
    """``f, f', f'', f'''`` of a two-node spring in its extension (``COL_PEN`` 0).

    The dome's first three are the lattice's own (:func:`.lattice.dome_law`).
    """
    if spring == SPRING_DOME:
        f, f1, f2 = dome_law(x_bar, row)
        kb = row[COL_KB]
        oma = 1.0 - row[COL_ALPHA]
        d = row[COL_D]
        u = x_bar / d
        f3 = kb * oma * (12.0 * u - 6.0) / d
        return f, f1, f2, f3
    k = row[COL_KPOST] if spring == SPRING_POST else row[COL_KLIM]
    return 0.5 * k * x_bar * x_bar, k * x_bar, k, 0.0


@kernel(inline="always")
def _pair_param_tangent(spring, x_bar, row, dcol, own):
    """Changes of ``f, f', f''`` when the constants move by ``own · dcol`` (fixed ``x̄``)."""
    if spring == SPRING_DOME:
        kb = row[COL_KB]
        oma = 1.0 - row[COL_ALPHA]
        d = row[COL_D]
        u = x_bar / d
        dkb = own * dcol[COL_KB]
        dal = own * dcol[COL_ALPHA]
        dd = own * dcol[COL_D]
        x2 = x_bar * x_bar
        df = (
            0.5 * x2 * (1.0 + oma * (u * u - 2.0 * u)) * dkb
            - 0.5 * kb * x2 * (u * u - 2.0 * u) * dal
            + kb * oma * x2 * (u - u * u) / d * dd
        )
        df1 = (
            x_bar * (1.0 + oma * (2.0 * u * u - 3.0 * u)) * dkb
            - kb * x_bar * (2.0 * u * u - 3.0 * u) * dal
            + kb * oma * x_bar * (3.0 * u - 4.0 * u * u) / d * dd
        )
        df2 = (
            (1.0 + 6.0 * oma * (u * u - u)) * dkb
            - 6.0 * kb * (u * u - u) * dal
            + kb * oma * (6.0 * u - 12.0 * u * u) / d * dd
        )
        return df, df1, df2
    dk = own * (dcol[COL_KPOST] if spring == SPRING_POST else dcol[COL_KLIM])
    return 0.5 * x_bar * x_bar * dk, x_bar * dk, dk


@kernel(inline="always")
def _phi_hessian(vx, vy):
    """``Hφ(v) = [[h00, h01], [h01, -h00]]`` of the polar angle ``φ(v)``."""
    r2 = vx * vx + vy * vy
    r4 = r2 * r2
    return 2.0 * vx * vy / r4, (vy * vy - vx * vx) / r4


@kernel(inline="always")
def _curvature_form(vx, vy, rx, ry):
    """``ρᵀ Hφ(v) ρ`` and its gradient in ``v`` (``ρ = (rx, ry)`` fixed)."""
    a = rx * rx - ry * ry
    b = 2.0 * rx * ry
    r2 = vx * vx + vy * vy
    r4 = r2 * r2
    r6 = r4 * r2
    num = 2.0 * vx * vy * a + (vy * vy - vx * vx) * b
    gx = (2.0 * vy * a - 2.0 * vx * b) / r4 - 4.0 * num * vx / r6
    gy = (2.0 * vx * a + 2.0 * vy * b) / r4 - 4.0 * num * vy / r6
    return num / r4, gx, gy


@kernel(inline="always")
def _torsion_geometry(pos, angle):
    """Arms, deviation ``δ`` and ``∇φ`` of both arms of an :data:`~.records.Angle` (see lattice).

    Returns a :data:`~.records.TorsionArms`.
    """
    a, c, b = angle
    vax = pos[a, 0] - pos[c, 0]
    vay = pos[a, 1] - pos[c, 1]
    vbx = pos[b, 0] - pos[c, 0]
    vby = pos[b, 1] - pos[c, 1]
    delta = math.atan2(-(vax * vbx + vay * vby), vax * vby - vay * vbx)
    ra2 = vax * vax + vay * vay
    rb2 = vbx * vbx + vby * vby
    return TorsionArms(vax, vay, vbx, vby, delta, -vay / ra2, vax / ra2, -vby / rb2, vbx / rb2)


@kernel(inline="always")
def _torsion_curvature_terms(arms, r, angle):
    """Pieces of ``rᵀ∇²E r = k_t G² + k_t δ S`` of one torsional spring at fixed ``r``.

    ``arms``: the spring's :data:`~.records.TorsionArms` at the point; ``angle``: its nodes.

    Returns ``(ρ_a, ρ_b, G, ∇_{v_a} ρ_aᵀHφ(v_a)ρ_a, ∇_{v_b} ρ_bᵀHφ(v_b)ρ_b, S)``, vectors as
    two numbers: ``ρ_a = r_a - r_c``, ``ρ_b = r_b - r_c``, ``G = ∇δ·r`` and
    ``S = ρ_bᵀHφ(v_b)ρ_b - ρ_aᵀHφ(v_a)ρ_a``.
    """
    vax, vay, vbx, vby, _, gax, gay, gbx, gby = arms
    a, c, b = angle
    rax, ray = _node_vector(r, a)
    rbx, rby = _node_vector(r, b)
    rcx, rcy = _node_vector(r, c)
    pax = rax - rcx
    pay = ray - rcy
    pbx = rbx - rcx
    pby = rby - rcy
    G = gbx * pbx + gby * pby - gax * pax - gay * pay
    qa, qax, qay = _curvature_form(vax, vay, pax, pay)
    qb, qbx, qby = _curvature_form(vbx, vby, pbx, pby)
    return pax, pay, pbx, pby, G, qax, qay, qbx, qby, qb - qa


@kernel
def third_derivative_contraction(pos, unit_params, h, r, w):
    """``w = ∇_x (rᵀ H(x) r)`` at fixed ``r`` (N/mm² · mm²/mm): the Hessian's derivative along r.

    Per two-node spring, with ``q = r_a - r_b`` and ``s = e·q``:
    ``rᵀH r = f'' s² + (f'/ℓ)(|q|² - s²)``, whose gradient in ``x_a - x_b`` is
    ``(f''' s² + (f''/ℓ - f'/ℓ²)(|q|² - s²)) e + 2 s (f'' - f'/ℓ)(q - s e)/ℓ``. Per torsional
    spring, with ``ρ_a = r_a - r_c``, ``ρ_b = r_b - r_c``, ``G = ∇δ·r`` and
    ``S = ρ_bᵀHφ(v_b)ρ_b - ρ_aᵀHφ(v_a)ρ_a``: ``rᵀ∇²E r = k_t G² + k_t δ S``, differentiated
    in both arms. ``pos`` must hold the node positions at the point (``assemble`` fills it).
    """
    n_units = unit_params.shape[0]
    for i in range(n_free(n_units)):
        w[i] = 0.0
    for k in range(1, n_units + 1):
        row = unit_params[k - 1]
        p = row[COL_P]
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            if free_node(a) < 0 and free_node(b) < 0:
                continue
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            ell = math.sqrt(dx * dx + dy * dy)
            ex = dx / ell
            ey = dy / ell
            _, f1, f2, f3 = _pair_scalars(spring, ell - rest, row)
            rax, ray = _node_vector(r, a)
            rbx, rby = _node_vector(r, b)
            qx = rax - rbx
            qy = ray - rby
            s = ex * qx + ey * qy
            perp = qx * qx + qy * qy - s * s
            along = f3 * s * s + (f2 / ell - f1 / (ell * ell)) * perp
            across = 2.0 * s * (f2 - f1 / ell) / ell
            gx = along * ex + across * (qx - s * ex)
            gy = along * ey + across * (qy - s * ey)
            _add(w, a, gx, gy)
            _add(w, b, -gx, -gy)
        kt = row[COL_KT]
        _torsion_contraction(pos, Angle(2 * k - 1, 2 * k + 1, 2 * k), kt, r, w)
        if k < n_units:
            _torsion_contraction(pos, Angle(2 * k, 2 * k + 1, 2 * k + 3), kt, r, w)


@kernel(inline="always")
def _torsion_contraction(pos, angle, kt, r, w):
    arms = _torsion_geometry(pos, angle)
    vax, vay, vbx, vby, delta, gax, gay, gbx, gby = arms
    a, c, b = angle
    pax, pay, pbx, pby, G, qax, qay, qbx, qby, S = _torsion_curvature_terms(arms, r, angle)
    ha00, ha01 = _phi_hessian(vax, vay)
    hb00, hb01 = _phi_hessian(vbx, vby)
    # ∂/∂v_a = -2 k_t G Hφ(v_a)ρ_a - k_t S ∇φ(v_a) - k_t δ ∇(ρ_aᵀHφρ_a), and for v_b with +.
    two_g = 2.0 * kt * G
    ua_x = -two_g * (ha00 * pax + ha01 * pay) - kt * S * gax - kt * delta * qax
    ua_y = -two_g * (ha01 * pax - ha00 * pay) - kt * S * gay - kt * delta * qay
    ub_x = two_g * (hb00 * pbx + hb01 * pby) + kt * S * gbx + kt * delta * qbx
    ub_y = two_g * (hb01 * pbx - hb00 * pby) + kt * S * gby + kt * delta * qby
    _add(w, a, ua_x, ua_y)
    _add(w, b, ub_x, ub_y)
    _add(w, c, -ua_x - ub_x, -ua_y - ub_y)


@kernel(inline="always")
def _torsion_tangent(pos, angle, kt, dkt, dp1, dh, r, dg):
    """Tangent of one torsional spring; returns ``(δE, δ(rᵀ∇²E r))`` and adds ``δg`` to dg."""
    arms = _torsion_geometry(pos, angle)
    vax, vay, vbx, vby, delta, gax, gay, gbx, gby = arms
    a, c, b = angle
    max_, may = _clamp_motion(a, dp1, dh)
    mbx, mby = _clamp_motion(b, dp1, dh)
    mcx, mcy = _clamp_motion(c, dp1, dh)
    dvax = max_ - mcx
    dvay = may - mcy
    dvbx = mbx - mcx
    dvby = mby - mcy
    ddelta = gbx * dvbx + gby * dvby - gax * dvax - gay * dvay
    ha00, ha01 = _phi_hessian(vax, vay)
    hb00, hb01 = _phi_hessian(vbx, vby)
    dgax = ha00 * dvax + ha01 * dvay
    dgay = ha01 * dvax - ha00 * dvay
    dgbx = hb00 * dvbx + hb01 * dvby
    dgby = hb01 * dvbx - hb00 * dvby
    s1 = dkt * delta + kt * ddelta
    s2 = kt * delta
    ax = -(s1 * gax + s2 * dgax)
    ay = -(s1 * gay + s2 * dgay)
    bx = s1 * gbx + s2 * dgbx
    by = s1 * gby + s2 * dgby
    _add(dg, a, ax, ay)
    _add(dg, b, bx, by)
    _add(dg, c, -ax - bx, -ay - by)
    d_energy = 0.5 * dkt * delta * delta + kt * delta * ddelta
    # rᵀ∇²E r = k_t G² + k_t δ S at fixed r.
    pax, pay, pbx, pby, G, qax, qay, qbx, qby, S = _torsion_curvature_terms(arms, r, angle)
    dG = dgbx * pbx + dgby * pby - dgax * pax - dgay * pay
    dS = qbx * dvbx + qby * dvby - qax * dvax - qay * dvay
    d_phi = dkt * (G * G + delta * S) + kt * (2.0 * G * dG + ddelta * S + delta * dS)
    return d_energy, d_phi


@kernel
def tangent(pos, lattice, dtab, parameter, r, dg):
    """Forward-mode derivative of gradient, energy and ``rᵀHr`` in one design parameter.

    Parameters
    ----------
    pos : ndarray of shape (2N + 2, 2), mm
        Node positions at the point (free coordinates held fixed).
    lattice : Lattice
        The design's ``unit_params`` (N, N_COLS) and ``h`` (mm) (:mod:`.records`).
    dtab : ndarray of shape (N, N_DCONST, N_DPARAM)
        Derivatives of every unit's constants (:func:`.tables.design_tables.design_tables`).
    parameter : TangentParameter
        The parameter's ``kind`` (``DP_*``, column of ``dtab``), its ``unit`` (1-based, or -1
        for the shared ``t`` and ``t_lim``) and the units ``k_lo .. k_hi`` whose springs it
        touches (:mod:`.records`).
    r : ndarray of shape (4N - 2,)
        Fixed vector of the ``rᵀHr`` tangent (zeros when not wanted).
    dg : ndarray of shape (4N - 2,)
        Receives ``∂g/∂θ`` (N per unit of θ).

    Returns
    -------
    d_energy : float
        ``∂E/∂θ`` at fixed ``x``.
    d_phi : float
        ``∂(rᵀ H r)/∂θ`` at fixed ``x`` and ``r``.
    """
    unit_params, h = lattice
    kind, unit, k_lo, k_hi = parameter
    n_units = unit_params.shape[0]
    for i in range(n_free(n_units)):
        dg[i] = 0.0
    # Motion of the clamped nodes: p_1 moves L_1, h moves L_0 and L_1.
    dp1 = dtab[0, COL_P, kind] if unit == -1 or unit == 1 else 0.0
    dh = dtab[0, DC_H, kind]
    d_energy = 0.0
    d_phi = 0.0
    for k in range(k_lo, k_hi + 1):
        row = unit_params[k - 1]
        dcol = dtab[k - 1, :, kind]
        # Only the parameter's own unit moves its constants (all units for t and t_lim).
        own = 1.0 if unit == -1 or unit == k else 0.0
        p = row[COL_P]
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            if free_node(a) < 0 and free_node(b) < 0:
                continue
            drest = dh if spring == SPRING_POST else own * dcol[COL_P]
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            ell = math.sqrt(dx * dx + dy * dy)
            ex = dx / ell
            ey = dy / ell
            x_bar = ell - rest
            _, f1, f2, f3 = _pair_scalars(spring, x_bar, row)
            df_p, df1_p, df2_p = _pair_param_tangent(spring, x_bar, row, dcol, own)
            max_, may = _clamp_motion(a, dp1, dh)
            mbx, mby = _clamp_motion(b, dp1, dh)
            ddx = max_ - mbx
            ddy = may - mby
            dl = ex * ddx + ey * ddy
            dxbar = dl - drest
            d_energy += f1 * dxbar + df_p
            df1 = f2 * dxbar + df1_p
            dex = (ddx - ex * dl) / ell
            dey = (ddy - ey * dl) / ell
            gx = df1 * ex + f1 * dex
            gy = df1 * ey + f1 * dey
            _add(dg, a, gx, gy)
            _add(dg, b, -gx, -gy)
            rax, ray = _node_vector(r, a)
            rbx, rby = _node_vector(r, b)
            qx = rax - rbx
            qy = ray - rby
            s = ex * qx + ey * qy
            ds = dex * qx + dey * qy
            perp = qx * qx + qy * qy - s * s
            df2 = f3 * dxbar + df2_p
            d_phi += (
                df2 * s * s
                + 2.0 * f2 * s * ds
                + (df1 / ell - f1 * dl / (ell * ell)) * perp
                - 2.0 * (f1 / ell) * s * ds
            )
        kt = row[COL_KT]
        dkt = own * dcol[COL_KT]
        de, dp = _torsion_tangent(pos, Angle(2 * k - 1, 2 * k + 1, 2 * k), kt, dkt, dp1, dh, r, dg)
        d_energy += de
        d_phi += dp
        if k < n_units:
            angle = Angle(2 * k, 2 * k + 1, 2 * k + 3)
            de, dp = _torsion_tangent(pos, angle, kt, dkt, dp1, dh, r, dg)
            d_energy += de
            d_phi += dp
    return d_energy, d_phi


@kernel(inline="always")
def _node_total(node, dx, dp1, dh):
    """Total derivative of a node: ``dx*/dθ`` at free nodes, clamp motion at clamped ones."""
    if free_node(node) < 0:
        return _clamp_motion(node, dp1, dh)
    return _node_vector(dx, node)


@kernel
def design_sensitivities(x, lattice, derivatives, stride, out, ws):
    """All sensitivities of the minimum ``x`` of one design (see the module docstring).

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        A minimum (the state search's returned shape).
    lattice : Lattice
        Physical table ``unit_params`` (N, N_COLS; no steering penalty) and ``h`` (mm).
    derivatives : DesignDerivatives
        Derivative table ``dtab`` (N, N_DCONST, N_DPARAM) of
        :func:`.tables.design_tables.design_tables` and Young's modulus ``E`` (MPa; for the
        closed-form ``E`` column).
    stride : int
        Columns per per-unit kind in the outputs: ``N`` for one design's own table,
        ``MAX_UNITS`` for the padded batch columns (see :func:`parameter_column`).
    out : SensitivityRows
        ``sens`` (N_SENS, 3 stride + 3) receives ``d(output)/dθ`` (rows ``SENS_*``; NaN where
        undefined or past ``N``); ``dxs`` (4N - 2 or more, 3 stride + 3), or (0, 0), receives
        ``dx*/dθ`` when not empty.
    ws : tuple
        From :func:`workspace`.

    Returns
    -------
    bool
        False (and everything NaN) when the Hessian at ``x`` is not positive definite.
    """
    pos, grad, hess, low, r, w, dg, dx, split = ws
    unit_params, h = lattice
    dtab, E = derivatives
    sens, dx_out = out
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    keep_dx = dx_out.shape[0] > 0
    sens[:, :] = np.nan
    if keep_dx:
        dx_out[:, :] = np.nan
    energy = assemble(x, unit_params, h, pos, grad, hess, HESSIAN, split)
    if not cholesky(hess, 0.0, low, nf):
        return False
    tip = 2 * n_units + 1
    ftip = free_node(tip)
    # The unit load n normal to the last layer segment, r = H⁻¹ n and K = 1/(n·r), by
    # states.tip_stiffness (r stays zero where the tip is clamped).
    seg_x = pos[tip, 0] - pos[tip - 2, 0]
    seg_y = pos[tip, 1] - pos[tip - 2, 1]
    seg2 = seg_x * seg_x + seg_y * seg_y
    seg = math.sqrt(seg2)
    nx = -seg_y / seg
    ny = seg_x / seg
    for i in range(nf):
        r[i] = 0.0
    stiffness = tip_stiffness(pos, low, True, dg, r, n_units)
    if ftip >= 0:
        third_derivative_contraction(pos, unit_params, h, r, w)
    bend, length = layer_bend(pos, n_units)
    for kind in range(N_DPARAM):
        per_unit = kind < DP_T
        n_dir = n_units if per_unit else 1
        for j in range(n_dir):
            unit = j + 1 if per_unit else -1
            dp1 = dtab[0, COL_P, kind] if unit == -1 or unit == 1 else 0.0
            dh = dtab[0, DC_H, kind]
            if per_unit:
                k_lo = unit
                k_hi = min(unit + 1, n_units) if (unit == 1 and dp1 != 0.0) else unit
            else:
                k_lo = 1
                k_hi = n_units
            parameter = TangentParameter(kind, unit, k_lo, k_hi)
            d_energy, d_phi = tangent(pos, Lattice(unit_params, h), dtab, parameter, r, dg)
            cholesky_solve(low, dg, dx, nf)
            for i in range(nf):
                dx[i] = -dx[i]
            col = parameter_column(kind, unit, stride)
            if keep_dx:
                for i in range(nf):
                    dx_out[i, col] = dx[i]
            tx, ty = _node_total(tip, dx, dp1, dh)
            bx, by = _node_total(tip - 2, dx, dp1, dh)
            dsx = tx - bx
            dsy = ty - by
            d_bend = (seg_x * dsy - seg_y * dsx) / seg2
            d_length = 0.0
            for k in range(1, n_units + 1):
                ax, ay = _node_total(2 * k + 1, dx, dp1, dh)
                cx, cy = _node_total(2 * k - 1, dx, dp1, dh)
                sx = pos[2 * k + 1, 0] - pos[2 * k - 1, 0]
                sy = pos[2 * k + 1, 1] - pos[2 * k - 1, 1]
                d_length += (sx * (ax - cx) + sy * (ay - cy)) / math.sqrt(sx * sx + sy * sy)
            g_dx = 0.0
            for i in range(nf):
                g_dx += grad[i] * dx[i]
            sens[SENS_TIP_X, col] = tx
            sens[SENS_TIP_Y, col] = ty
            sens[SENS_BEND, col] = d_bend
            sens[SENS_CURVATURE, col] = d_bend / length - bend * d_length / (length * length)
            sens[SENS_ENERGY, col] = d_energy + g_dx
            if ftip >= 0:
                dnx = -dsy / seg - nx * (seg_x * dsx + seg_y * dsy) / seg2
                dny = dsx / seg - ny * (seg_x * dsx + seg_y * dsy) / seg2
                w_dx = 0.0
                for i in range(nf):
                    w_dx += w[i] * dx[i]
                dn_r = dnx * r[2 * ftip] + dny * r[2 * ftip + 1]
                sens[SENS_STIFFNESS, col] = -stiffness * stiffness * (2.0 * dn_r - (d_phi + w_dx))
    # E: shapes do not depend on it; energy and stiffness are proportional to it.
    col = parameter_column(N_DPARAM, -1, stride)
    if keep_dx:
        for i in range(nf):
            dx_out[i, col] = 0.0
    sens[SENS_TIP_X, col] = 0.0
    sens[SENS_TIP_Y, col] = 0.0
    sens[SENS_BEND, col] = 0.0
    sens[SENS_CURVATURE, col] = 0.0
    sens[SENS_ENERGY, col] = energy / E
    if ftip >= 0:
        sens[SENS_STIFFNESS, col] = stiffness / E
    return True
