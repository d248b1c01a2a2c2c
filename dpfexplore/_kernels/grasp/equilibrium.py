"""The finger's equilibrium against the disk: Newton, augmented Lagrangian, growth into place.

Newton
    :func:`minimize_contact` is the project's globalised Newton
    (:func:`dpfexplore._kernels.statics.newton.minimize`) on the energy with contact: a Newton
    step where the Hessian factors (block Cholesky: every segment joins adjacent posts, so the
    Hessian stays block tridiagonal), a step on the convexified Hessian (lattice springs'
    curvatures made non-negative, the contact's Gauss-Newton part) capped at ``max_step`` where
    it does not, and a backtracking Armijo search on the energy. For fixed shifts the energy is a
    potential, so every accepted step decreases it.
Augmented Lagrangian
    :func:`equilibrium` minimises with the shifts fixed, then moves each shift by the segment's
    gap (``σ ← max(0, σ - g)``: Uzawa's update of the multiplier ``κσ``) until no penetration
    exceeds ``tol``. The friction loads are updated at the same time from the new normal forces.
    The penetration falls by about ``K / (K + κ)`` per update, ``K`` the finger's stiffness at the
    contact.
Growth into place
    :func:`grasp_solve` starts from the free state; if the disk overlaps it, the disk is grown
    from the radius that just touches to its own, by at most ``grow`` per step, each step
    starting from the last: the closing finger meets the object from outside, never through it.
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from ...model.domain import MAX_UNITS
from .._jit import kernel
from ..lattice import ENERGY, HESSIAN, HESSIAN_CONVEX, dome_law, unpack_nodes
from ..layout import COL_D, COL_P, COL_U_INV, n_free, n_nodes
from ..linalg.cholesky import cholesky, cholesky_solve, max_abs
from ..statics.newton import ARMIJO, MAX_BACKTRACKS, ROUNDOFF_ULPS, _shifted_step
from .contact import energy_with_contact, penalty, segment_gap
from .records import (
    G_CAGE,
    G_DOME1_EXT,
    G_DOME1_FORCE,
    G_ENERGY,
    G_FRICTION,
    G_GRIP,
    G_HOLDS,
    G_ITER,
    G_LATTICE_ENERGY,
    G_PENETRATION,
    G_STATUS,
    LOAD_S,
    LOAD_X,
    LOAD_Y,
    SEG_FORCE,
    SEG_GAP,
    SEG_NX,
    SEG_NY,
    SEG_PX,
    SEG_PY,
    SEG_S,
    SHIFT,
    Disk,
)


@kernel
def workspace():
    """Scratch for one contact solve (largest design): the lattice's and the contact's.

    Returns ``(pos, grad, hess, low, step, trial, split, dg, d2g, x0)``.
    """
    nf = n_free(MAX_UNITS)
    return (
        np.empty((n_nodes(MAX_UNITS), 2)),
        np.empty(nf),
        np.empty((nf, nf)),
        np.empty((nf, nf)),
        np.empty(nf),
        np.empty(nf),
        np.empty(4),
        np.empty(4),
        np.empty((4, 4)),
        np.empty(nf),
    )


@kernel
def minimize_contact(x, lat, disk, contact, ctl, ws):
    """Minimise the energy with contact from ``x`` (in place), shifts and loads fixed.

    Returns ``(status, n_eval)`` as :func:`dpfexplore._kernels.statics.newton.minimize`.
    """
    _, grad, hess, low, step, trial = ws[:6]
    n = n_free(lat.unit_params.shape[0])
    kp = (ctl.kappa, ctl.eps)
    e, _ = energy_with_contact(x, lat, disk, contact, kp, HESSIAN, ws)
    n_eval = 1
    n_indefinite = 0
    while True:
        gnorm = max_abs(grad, n)
        if not (math.isfinite(e) and math.isfinite(gnorm)):
            return st.NONFINITE, n_eval
        positive = cholesky(hess, 0.0, low, n)
        for i in range(n):
            grad[i] = -grad[i]
        if positive:
            cholesky_solve(low, grad, step, n)
            if gnorm <= ctl.gtol or max_abs(step, n) <= ctl.xtol:
                for i in range(n):
                    x[i] += step[i]
                return st.OK, n_eval
        if n_eval >= ctl.max_iter:
            return st.NOT_CONVERGED, n_eval
        slope = 0.0
        if not positive:
            n_indefinite += 1
            shift = 1e-3
            if n_indefinite > 1:
                for i in range(n):
                    trial[i] = grad[i]
                energy_with_contact(x, lat, disk, contact, kp, HESSIAN_CONVEX, ws)
                for i in range(n):
                    grad[i] = trial[i]
                n_eval += 1
                shift = 0.0
            if not _shifted_step(hess, grad, shift, ctl.max_step, low, step, n):
                return st.NONFINITE, n_eval
        for i in range(n):
            slope -= grad[i] * step[i]
        tolerance = ROUNDOFF_ULPS * 2.220446049250313e-16 * abs(e)
        a = 1.0
        accepted = False
        e_trial = e
        for _attempt in range(MAX_BACKTRACKS):
            for i in range(n):
                trial[i] = x[i] + a * step[i]
            e_trial, _ = energy_with_contact(trial, lat, disk, contact, kp, ENERGY, ws)
            if e_trial <= e + ARMIJO * a * slope + tolerance:
                accepted = True
                break
            a *= 0.5
        if not accepted:
            if positive and gnorm <= 1e3 * ctl.gtol:
                return st.OK, n_eval
            return st.NOT_CONVERGED, n_eval
        for i in range(n):
            x[i] = trial[i]
        e, _ = energy_with_contact(x, lat, disk, contact, kp, HESSIAN, ws)
        n_eval += 1


@kernel
def segment_table(x, lat, disk, contact, ctl, ws, seg):
    """Fill ``seg`` ``(N, N_SEG)``: force, contact point, normal, gap, position per segment.

    Returns the largest penetration (mm, 0 without any).
    """
    pos, _, _, _, _, _, _, dg, d2g = ws[:9]
    from_lattice = lat.unit_params
    n_units = from_lattice.shape[0]
    worst = 0.0
    # node positions at x (the energy call fills them)
    energy_with_contact(x, lat, disk, contact, (ctl.kappa, ctl.eps), ENERGY, ws)
    for k in range(1, n_units + 1):
        a = 2 * k - 1
        b = 2 * k + 1
        gap, s, nx, ny = segment_gap(pos, a, b, disk, dg, d2g)
        _, psi1, _ = penalty(gap - contact[k - 1, SHIFT], ctl.kappa, ctl.eps)
        r = disk.radius + disk.offset
        seg[k - 1, SEG_FORCE] = -psi1
        seg[k - 1, SEG_PX] = disk.cx - nx * (r + gap)
        seg[k - 1, SEG_PY] = disk.cy - ny * (r + gap)
        seg[k - 1, SEG_NX] = nx
        seg[k - 1, SEG_NY] = ny
        seg[k - 1, SEG_GAP] = gap
        seg[k - 1, SEG_S] = s
        if psi1 < 0.0:
            worst = max(worst, -gap)
    return worst


@kernel
def friction_loads(disk, seg, contact):
    """Set each segment's friction load from its normal force; returns the largest change (N).

    The disk slides along the axis ``a`` away from the base; on each contact the friction on the
    finger is ``μ f`` along the tangent's component of ``a`` (it drags the surface with the
    disk), on the disk the opposite.
    """
    change = 0.0
    for k in range(seg.shape[0]):
        f = seg[k, SEG_FORCE]
        tx = -seg[k, SEG_NY]
        ty = seg[k, SEG_NX]
        along = tx * disk.ax + ty * disk.ay
        qx = 0.0
        qy = 0.0
        if f > 0.0 and disk.mu > 0.0 and along != 0.0:
            sign = 1.0 if along > 0.0 else -1.0
            qx = disk.mu * f * sign * tx
            qy = disk.mu * f * sign * ty
        change = max(change, abs(qx - contact[k, LOAD_X]), abs(qy - contact[k, LOAD_Y]))
        contact[k, LOAD_X] = qx
        contact[k, LOAD_Y] = qy
        contact[k, LOAD_S] = seg[k, SEG_S]
    return change


@kernel
def equilibrium(x, lat, disk, contact, ctl, ws, seg):
    """Equilibrium against the disk to ``tol`` of penetration (augmented Lagrangian).

    Returns ``(status, n_eval, penetration)``; ``seg`` holds the per-segment table at the end.
    """
    n_total = 0
    worst = 0.0
    for _outer in range(ctl.max_outer):
        status, n_eval = minimize_contact(x, lat, disk, contact, ctl, ws)
        n_total += n_eval
        if status != st.OK:
            return status, n_total, math.nan
        worst = segment_table(x, lat, disk, contact, ctl, ws, seg)
        change = friction_loads(disk, seg, contact) if disk.mu > 0.0 else 0.0
        load_ok = change <= 1e-9 + 1e-6 * max_force(seg)
        if worst <= ctl.tol and load_ok:
            return st.OK, n_total, worst
        for k in range(seg.shape[0]):
            contact[k, SHIFT] = max(0.0, contact[k, SHIFT] - seg[k, SEG_GAP])
    return st.NOT_CONVERGED, n_total, worst


@kernel
def max_force(seg):
    """Largest normal force of a segment table (N)."""
    m = 0.0
    for k in range(seg.shape[0]):
        m = max(m, seg[k, SEG_FORCE])
    return m


@kernel
def first_touch(x, lat, disk, ws):
    """Radius (mm) at which a disk at ``disk``'s centre first touches the finger at ``x``."""
    pos, _, _, _, _, _, _, dg, d2g = ws[:9]
    probe = Disk(disk.cx, disk.cy, 0.0, disk.offset, disk.ax, disk.ay, disk.mu)
    unpack_nodes(x, lat.unit_params, lat.h, pos)
    smallest = math.inf
    for k in range(1, lat.unit_params.shape[0] + 1):
        gap, _, _, _ = segment_gap(pos, 2 * k - 1, 2 * k + 1, probe, dg, d2g)
        smallest = min(smallest, gap)
    return smallest


@kernel
def grasp_solve(x, lat, disk, contact, ctl, ws, seg, out):
    """The finger's equilibrium with the disk in place, grown from first touch; fills ``out``.

    ``x`` (free coordinates, mm) starts at the free state and ends at the equilibrium;
    ``contact`` starts at zero (or a previous solve's shifts and loads); ``out`` has the
    ``G_*`` columns of :mod:`.records`.
    """
    for i in range(out.shape[0]):
        out[i] = math.nan
    touch = first_touch(x, lat, disk, ws)
    n_total = 0
    status = st.OK
    worst = 0.0
    radius = disk.radius
    if touch < radius:
        r = max(touch, 0.0)
        while True:
            r = min(radius, r + ctl.grow)
            step_disk = Disk(disk.cx, disk.cy, r, disk.offset, disk.ax, disk.ay, disk.mu)
            status, n_eval, worst = equilibrium(x, lat, step_disk, contact, ctl, ws, seg)
            n_total += n_eval
            if status != st.OK or r >= radius:
                break
    else:
        status, n_eval, worst = equilibrium(x, lat, disk, contact, ctl, ws, seg)
        n_total += n_eval
    out[G_STATUS] = status
    out[G_ITER] = n_total
    if status != st.OK:
        return status
    outputs(x, lat, disk, contact, ctl, ws, seg, out)
    out[G_PENETRATION] = worst
    return status


@kernel
def outputs(x, lat, disk, contact, ctl, ws, seg, out):
    """Grip force, unit 1's dome, the cage and friction terms, holding, energies into ``out``."""
    pos = ws[0]
    total, e_lattice = energy_with_contact(x, lat, disk, contact, (ctl.kappa, ctl.eps), ENERGY, ws)
    out[G_ENERGY] = total
    out[G_LATTICE_ENERGY] = e_lattice
    grip = 0.0
    cage = 0.0
    friction = 0.0
    for k in range(seg.shape[0]):
        f = seg[k, SEG_FORCE]
        grip += f
        # force on the disk f n; both fingers' components along the axis add up
        cage -= 2.0 * f * (seg[k, SEG_NX] * disk.ax + seg[k, SEG_NY] * disk.ay)
        friction += 2.0 * f * abs(-seg[k, SEG_NY] * disk.ax + seg[k, SEG_NX] * disk.ay)
    out[G_GRIP] = grip
    out[G_CAGE] = cage
    out[G_FRICTION] = friction
    row = lat.unit_params[0]
    dx = pos[2, 0] - pos[0, 0]
    dy = pos[2, 1] - pos[0, 1]
    ext = math.sqrt(dx * dx + dy * dy) - row[COL_P]
    _, f1, _ = dome_law(ext, row)
    out[G_DOME1_FORCE] = f1
    out[G_DOME1_EXT] = ext
    holds = 1.0
    for k in range(1, lat.unit_params.shape[0] + 1):
        row = lat.unit_params[k - 1]
        dx = pos[2 * k, 0] - pos[2 * k - 2, 0]
        dy = pos[2 * k, 1] - pos[2 * k - 2, 1]
        u = (math.sqrt(dx * dx + dy * dy) - row[COL_P]) / row[COL_D]
        inverted = 1 if u > row[COL_U_INV] else 0
        if inverted != lat.bits[k - 1]:
            holds = 0.0
    out[G_HOLDS] = holds
