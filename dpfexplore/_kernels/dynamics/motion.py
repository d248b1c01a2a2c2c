"""Right-hand side of the damped lattice under pressure, and its Jacobians (MODEL.md §8).

Equations of motion on the free coordinates ``x`` (mm), velocities ``v`` (mm/s)::

    M a = F_ext(x, t) - ∇E(x) - F_damp(x, v) - η_iso v

* ``∇E`` and its Jacobian (the Hessian) come from :func:`.lattice.assemble`: the project's one
  energy, gradient and Hessian.
* ``M``: lumped masses, ``7e-6 · N/5`` tonne shared equally by all ``2N + 2`` nodes (the clamped
  nodes' share is simply not used).
* ``F_damp``: the paper's internal damping on every two-node spring (posts, limiting layer,
  domes) with ``x_ab = x_a - x_b``, ``v_ab = v_a - v_b``, rest length ``s``::

      f_a = η ((1 - s/ℓ) v_ab + s/ℓ³ (x_ab·v_ab) x_ab),   f_b = -f_a.

  This is ``η K_s v_ab`` with ``K_s = e eᵀ + (1 - s/ℓ)(I - e eᵀ)`` the tangent stiffness of a
  *unit* linear spring of rest length ``s``: the dashpot is "proportional to the spring", and the
  damping matrix ``C = ∂F_damp/∂v + η_iso I`` is ``η`` times the Hessian of
  ``Σ ½ (ℓ - s)²`` plus the drag. The lattice's scatter routine therefore assembles it, with
  ``f' = ℓ - s`` and ``f'' = 1``. ``C`` is symmetric but not always positive definite: a
  compressed spring (``ℓ < s``) has negative transverse damping ``η (1 - s/ℓ)``, which the
  isotropic drag normally outweighs (the paper's "numerical stability" term).
* ``F_ext``: pressure ``P(t)`` on the chamber faces, ``P · ℓ`` along the face's unit normal,
  half to each end node. With the face running from node ``a`` to node ``b``, ``P ℓ n̂`` is
  ``P`` times the face vector rotated by ±90°, so the load is *linear* in the positions and its
  Jacobian is constant for a given ``P``:

  - limiting-layer faces ``L_{k-1} → L_k``, rotated counter-clockwise (away from the dome line),
  - dome faces ``D_{k-1} → D_k``, rotated clockwise (away from the limiting layer),
  - posts ``D_k → L_k``, ``k = 1..N``, rotated clockwise (toward the tip).

  These are the implementation's conventions (verified against ``reference/rhs.csv``).

Pressure profiles are piecewise linear: knot times ``knot_t`` (s, non-decreasing) and pressures
``knot_p`` (MPa); before the first knot the first pressure holds, after the last the last.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..lattice import (
    GRADIENT,
    HESSIAN,
    N_SPLIT,
    _add_block,
    _scatter_pair,
    assemble,
    dome_extensions,
    spring_nodes,
)
from ..layout import COL_P, COL_U_INV, free_node, n_free, n_nodes

#: Total finger mass per unit, tonne (MODEL.md §8: 7e-6 · N/5).
MASS_PER_UNIT = 7e-6 / 5.0
#: Internal damping coefficient η of every two-node spring, N·s/mm (= tonne/s).
ETA_INTERNAL = 0.05
#: Isotropic drag η_iso on every node, N·s/mm.
ETA_ISO = 0.01

#: Layout of the ``phys`` array the kernels take: ``(η, η_iso, node mass)``.
PHYS_ETA = 0
PHYS_ETA_ISO = 1
PHYS_MASS = 2
N_PHYS = 3


@kernel
def node_mass(n_units):
    """Lumped mass of one node, tonne: ``7e-6 · N/5`` shared by ``2N + 2`` nodes."""
    return MASS_PER_UNIT * n_units / (2.0 * n_units + 2.0)


@kernel
def pressure_at(t, knot_t, knot_p):
    """Pressure (MPa) of a piecewise-linear profile at time ``t`` (s)."""
    n = knot_t.shape[0]
    if t <= knot_t[0]:
        return knot_p[0]
    if t >= knot_t[n - 1]:
        return knot_p[n - 1]
    for i in range(1, n):
        if t < knot_t[i]:
            t0 = knot_t[i - 1]
            t1 = knot_t[i]
            if t1 <= t0:
                return knot_p[i]
            w = (t - t0) / (t1 - t0)
            return knot_p[i - 1] + w * (knot_p[i] - knot_p[i - 1])
    return knot_p[n - 1]


@kernel
def _add_node_force(out, node, fx, fy):
    f = free_node(node)
    if f >= 0:
        out[2 * f] += fx
        out[2 * f + 1] += fy


@kernel
def add_pressure_forces(pos, n_units, pressure, out):
    """Add the pressure load (N) on the free coordinates to ``out``.

    ``pos`` holds all node positions (mm); ``pressure`` is in MPa.
    """
    if pressure == 0.0:
        return
    half = 0.5 * pressure
    for k in range(1, n_units + 1):
        # Face vectors a -> b; counter-clockwise rotation of (vx, vy) is (-vy, vx).
        for face in range(3):
            if face == 0:  # limiting layer L_{k-1} -> L_k, counter-clockwise
                a, b, sign = 2 * k - 1, 2 * k + 1, 1.0
            elif face == 1:  # dome D_{k-1} -> D_k, clockwise
                a, b, sign = 2 * k - 2, 2 * k, -1.0
            else:  # post D_k -> L_k, clockwise (toward the tip)
                a, b, sign = 2 * k, 2 * k + 1, -1.0
            vx = pos[b, 0] - pos[a, 0]
            vy = pos[b, 1] - pos[a, 1]
            fx = -sign * half * vy
            fy = sign * half * vx
            _add_node_force(out, a, fx, fy)
            _add_node_force(out, b, fx, fy)


@kernel
def add_pressure_jacobian(n_units, pressure, jac):
    """Add ``∂F_ext/∂x`` (N/mm) to ``jac``: constant for a given pressure, not symmetric.

    Each node of a face gets ``(sign P/2) R (x_b - x_a)`` with ``R`` the counter-clockwise
    rotation, so ``∂/∂x_b = sign P/2 R`` and ``∂/∂x_a = -sign P/2 R`` for both nodes.
    """
    if pressure == 0.0:
        return
    half = 0.5 * pressure
    for k in range(1, n_units + 1):
        for face in range(3):
            if face == 0:
                a, b, sign = 2 * k - 1, 2 * k + 1, 1.0
            elif face == 1:
                a, b, sign = 2 * k - 2, 2 * k, -1.0
            else:
                a, b, sign = 2 * k, 2 * k + 1, -1.0
            # R = [[0, -1], [1, 0]].
            r01 = -sign * half
            r10 = sign * half
            fa = free_node(a)
            fb = free_node(b)
            for node in (a, b):
                fn = free_node(node)
                _add_block(jac, fn, fb, 0.0, r01, r10, 0.0)
                _add_block(jac, fn, fa, 0.0, -r01, -r10, 0.0)


@kernel
def node_velocities(v, n_units, vel):
    """Fill ``vel`` (shape ``(2N + 2, 2)``, mm/s) from free velocities; clamped nodes at rest."""
    for node in range(n_nodes(n_units)):
        f = free_node(node)
        if f >= 0:
            vel[node, 0] = v[2 * f]
            vel[node, 1] = v[2 * f + 1]
        else:
            vel[node, 0] = 0.0
            vel[node, 1] = 0.0


@kernel
def add_damping_forces(pos, vel, unit_params, h, eta, out):
    """Add the internal damping force ``F_damp`` (N, as on the left-hand side) to ``out``."""
    n_units = unit_params.shape[0]
    for k in range(1, n_units + 1):
        p = unit_params[k - 1, COL_P]
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            if free_node(a) < 0 and free_node(b) < 0:
                continue
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            dvx = vel[a, 0] - vel[b, 0]
            dvy = vel[a, 1] - vel[b, 1]
            ell = math.sqrt(dx * dx + dy * dy)
            q = 1.0 - rest / ell
            w = rest / (ell * ell * ell) * (dx * dvx + dy * dvy)
            fx = eta * (q * dvx + w * dx)
            fy = eta * (q * dvy + w * dy)
            _add_node_force(out, a, fx, fy)
            _add_node_force(out, b, -fx, -fy)


@kernel
def damping_matrix(pos, unit_params, h, eta, eta_iso, scratch, cmat):
    """Fill ``cmat`` with ``C = ∂F_damp/∂v + η_iso I`` (N·s/mm), symmetric.

    Assembled by the lattice's own scatter routine as ``η`` times the Hessian of
    ``Σ ½ (ℓ - s)²`` over the two-node springs; ``scratch`` (shape ``(4N - 2,)``) receives the
    unused gradient.
    """
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    for i in range(nf):
        for j in range(nf):
            cmat[i, j] = 0.0
    for k in range(1, n_units + 1):
        p = unit_params[k - 1, COL_P]
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            if free_node(a) < 0 and free_node(b) < 0:
                continue
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            ell = math.sqrt(dx * dx + dy * dy)
            slopes = (eta * (ell - rest), eta)
            _scatter_pair(a, b, (dx / ell, dy / ell), ell, slopes, HESSIAN, scratch, cmat)
    for i in range(nf):
        cmat[i, i] += eta_iso


@kernel
def add_damping_position_jacobian(pos, vel, unit_params, h, eta, jac):
    """Add ``D = ∂F_damp/∂x`` (N/mm at the given velocities) to ``jac``.

    For one spring ``∂f_a/∂x_ab = η s/ℓ³ (v xᵀ + x vᵀ + (x·v) I - 3 (x·v) x xᵀ/ℓ²)`` with
    ``x = x_ab``, ``v = v_ab`` (symmetric); it enters ``(a, a)`` and ``(b, b)`` with ``+`` and
    ``(a, b)``, ``(b, a)`` with ``-``.
    """
    n_units = unit_params.shape[0]
    for k in range(1, n_units + 1):
        p = unit_params[k - 1, COL_P]
        for spring in range(3):
            a, b, rest = spring_nodes(k, spring, h, p)
            fa = free_node(a)
            fb = free_node(b)
            if fa < 0 and fb < 0:
                continue
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            dvx = vel[a, 0] - vel[b, 0]
            dvy = vel[a, 1] - vel[b, 1]
            ell2 = dx * dx + dy * dy
            ell = math.sqrt(ell2)
            xv = dx * dvx + dy * dvy
            c = eta * rest / (ell2 * ell)
            m00 = c * (2.0 * dvx * dx + xv - 3.0 * xv * dx * dx / ell2)
            m01 = c * (dvx * dy + dx * dvy - 3.0 * xv * dx * dy / ell2)
            m11 = c * (2.0 * dvy * dy + xv - 3.0 * xv * dy * dy / ell2)
            _add_block(jac, fa, fa, m00, m01, m01, m11)
            _add_block(jac, fb, fb, m00, m01, m01, m11)
            _add_block(jac, fa, fb, -m00, -m01, -m01, -m11)
            _add_block(jac, fb, fa, -m00, -m01, -m01, -m11)


@kernel(inline="always")
def _residual_from_gradient(v, t, model, scratch, out):
    """``out = R`` given ``∇E`` in ``work`` and the node positions in ``pos``.

    ``work`` is used as scratch afterwards; ``vel`` receives the node velocities. Returns the
    pressure (MPa) at ``t``.
    """
    unit_params, h, knot_t, knot_p, phys = model
    pos, vel, work = scratch
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    node_velocities(v, n_units, vel)
    eta_iso = phys[PHYS_ETA_ISO]
    for i in range(nf):
        out[i] = -work[i] - eta_iso * v[i]
        work[i] = 0.0
    add_damping_forces(pos, vel, unit_params, h, phys[PHYS_ETA], work)
    pressure = pressure_at(t, knot_t, knot_p)
    add_pressure_forces(pos, n_units, -pressure, work)
    for i in range(nf):
        out[i] -= work[i]
    return pressure


@kernel
def force_residual(x, v, t, model, scratch, out):
    """Fill ``out`` with ``R = F_ext - ∇E - F_damp - η_iso v`` (N), so that ``M a = R``.

    ``model`` is a :class:`~.records.MotionModel` (``phys`` is ``(η, η_iso, node mass)``),
    ``scratch`` a :class:`~.records.MotionScratch`; its ``pos`` holds the node positions on
    return. Returns the pressure (MPa) at ``t``.
    """
    split = np.empty(N_SPLIT)
    assemble(
        x, model.unit_params, model.h, scratch.pos, scratch.work, np.empty((0, 0)), GRADIENT, split
    )
    return _residual_from_gradient(v, t, model, scratch, out)


@kernel
def acceleration(x, v, t, model, scratch, acc):
    """Fill ``acc`` (mm/s²) with the accelerations ``R / m`` of the full second-order model.

    Arguments as for :func:`force_residual`; returns the pressure (MPa) at ``t``.
    """
    pressure = force_residual(x, v, t, model, scratch, acc)
    inv_m = 1.0 / model.phys[PHYS_MASS]
    for i in range(acc.shape[0]):
        acc[i] *= inv_m
    return pressure


@kernel
def static_force(x, t, unit_params, h, knot_t, knot_p, pos, out):
    """Fill ``out`` with ``G = F_ext - ∇E`` (N), the force the overdamped model balances."""
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    split = np.empty(N_SPLIT)
    assemble(x, unit_params, h, pos, out, np.empty((0, 0)), GRADIENT, split)
    for i in range(nf):
        out[i] = -out[i]
    pressure = pressure_at(t, knot_t, knot_p)
    add_pressure_forces(pos, n_units, pressure, out)
    return pressure


@kernel
def extension_margins(x, unit_params, h, pos, out):
    """Fill ``out`` with ``u_k - u_inversion_k``: the event functions (positive = inverted)."""
    dome_extensions(x, unit_params, h, pos, out)
    for k in range(unit_params.shape[0]):
        out[k] -= unit_params[k, COL_U_INV]


@kernel(inline="always")
def _finish_stiffness_jacobian(v, t, model, pos, vel, out):
    """``out``: from the Hessian to ``∂R/∂x = P_J - H - D`` (positions in ``pos``)."""
    unit_params, h, knot_t, knot_p, phys = model
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    node_velocities(v, n_units, vel)
    add_damping_position_jacobian(pos, vel, unit_params, h, phys[PHYS_ETA], out)
    for i in range(nf):
        for j in range(nf):
            out[i, j] = -out[i, j]
    add_pressure_jacobian(n_units, pressure_at(t, knot_t, knot_p), out)


@kernel
def stiffness_jacobian(x, v, t, model, scratch, out):
    """Fill ``out`` with ``∂R/∂x = P_J - H - D`` (N/mm) at ``(x, v, t)``.

    ``H`` is the analytic Hessian, ``D = ∂F_damp/∂x`` at the velocities ``v`` and ``P_J`` the
    pressure-follower Jacobian. Arguments as for :func:`force_residual`.
    """
    split = np.empty(N_SPLIT)
    assemble(x, model.unit_params, model.h, scratch.pos, scratch.work, out, HESSIAN, split)
    _finish_stiffness_jacobian(v, t, model, scratch.pos, scratch.vel, out)


@kernel
def residual_and_jacobian(x, v, t, model, scratch, res, jac):
    """:func:`force_residual` into ``res`` and :func:`stiffness_jacobian` into ``jac`` at once.

    The Hessian assembly computes the gradient on the way, so the residual at the same point
    costs only its damping and pressure terms: a Rosenbrock step needs both at its start.
    """
    split = np.empty(N_SPLIT)
    assemble(x, model.unit_params, model.h, scratch.pos, scratch.work, jac, HESSIAN, split)
    _finish_stiffness_jacobian(v, t, model, scratch.pos, scratch.vel, jac)
    return _residual_from_gradient(v, t, model, scratch, res)


@kernel
def full_jacobian(x, v, t, model, scratch, cmat, out):
    """Jacobian (shape ``(2n, 2n)``) of ``ẏ = [v, R/m]`` for ``y = [x, v]``, ``n = 4N - 2``.

    ``[[0, I], [(P_J - H - D)/m, -C/m]]``; ``cmat`` (shape ``(n, n)``) is scratch.
    """
    nf = x.shape[0]
    for i in range(2 * nf):
        for j in range(2 * nf):
            out[i, j] = 0.0
    for i in range(nf):
        out[i, nf + i] = 1.0
    block = out[nf:, :nf]
    stiff = np.empty((nf, nf))
    stiffness_jacobian(x, v, t, model, scratch, stiff)
    unit_params, h, _, _, phys = model
    damping_matrix(
        scratch.pos, unit_params, h, phys[PHYS_ETA], phys[PHYS_ETA_ISO], scratch.work, cmat
    )
    inv_m = 1.0 / phys[PHYS_MASS]
    for i in range(nf):
        for j in range(nf):
            block[i, j] = stiff[i, j] * inv_m
            out[nf + i, nf + j] = -cmat[i, j] * inv_m
