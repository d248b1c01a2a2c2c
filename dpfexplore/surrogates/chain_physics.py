"""The finger as a chain of units: exact per-unit kinematics and the rigid unit-cell model.

This is the physics of the chain surrogate (:mod:`dpfexplore.surrogates.chain`).

Kinematics (exact)
    Post ``k`` (MODEL.md §5) is the segment ``D_k -> L_k``; post 0 is clamped upright. A shape
    is described per unit ``k = 1..N`` by three numbers:

    * ``rho_k``: the turn of post ``k`` relative to post ``k - 1`` (rad, counter-clockwise);
    * ``beta_k``: the heading of limiting-layer segment ``L_{k-1} -> L_k`` relative to the
      normal of post ``k - 1`` (rad; ``beta_1 = 0``: the first segment is clamped);
    * ``ell_k``: that segment's length (mm; ``ell_1 = p_1``).

    The headings follow exactly: post ``k`` at ``psi_k = rho_1 + ... + rho_k``, segment ``k`` at
    ``theta_k = psi_{k-1} + beta_k``, and the tip is
    ``L_N = (0, h) + sum_k ell_k (cos theta_k, sin theta_k)`` (:func:`compose`). An error in
    ``rho_k`` turns everything beyond unit ``k`` (its arm is the distance to the tip); an error
    in ``beta_k`` or ``ell_k`` moves one segment only.

Why per unit
    A finger carries no load, so the part beyond a unit is self-equilibrated and barely loads it:
    measured on exact shapes of the paper's box, resampling unit ``j``'s parameters moves
    ``rho_{j+1}`` by ~2e-4 rad (through the stretch of their shared post), ``rho_{j+2}`` by
    ~1e-9 and the units before ``j`` by < 1e-7; removing the units beyond ``k`` changes
    nothing before ``k`` (< 2e-6 rad). So ``rho_k, beta_k, ell_k`` are functions of units
    ``k - 1`` and ``k`` and of whether ``k`` is the first or second unit (the clamp).

Rigid unit-cell model (approximate, closed-form constants, a 2-unknown Newton solve)
    Unit ``k`` alone, in the frame of post ``k - 1`` (upright, rest length ``h``), with rigid
    posts and an inextensible layer: its shape has two unknowns, the layer heading ``beta`` and
    the post turn ``rho``, and its energy is

        ``E(beta, rho) = E_dome(|D_k| - p) + 1/2 k_t,(k-1) beta^2 + 1/2 k_t,k (rho - beta)^2``

    with ``D_k = (p cos beta + h sin rho, h + p sin beta - h cos rho)`` (the dome spring of
    MODEL.md §4 and the two torsion springs of the unit's layer segment; unit 1 has
    ``beta = 0`` and only the second spring). Its minimum on the requested side gives
    ``rho_k`` to ~3e-4 rad and ``beta_k`` to ~2e-4 rad in the paper's box (what it leaves out:
    post and layer stretch). Whether that minimum exists says whether the unit's dome stays
    inverted in its finger: "every unit holds" agrees with the exact model's existence of the
    all-inverted state on 99.97 % of the paper's designs.

    Holding margin: with ``beta`` slaved to ``rho``, the unit's energy ``V(rho)`` rises from the
    flat state to a barrier and falls to the inverted minimum; the minimum exists exactly when
    ``V'`` is negative somewhere. Linearised (``e = h rho``), ``V'`` is a cubic in ``u = e/d``
    whose lowest point is at ``u* = (1 + sqrt(1 - 2 (1 + kappa) / (3 (1 - alpha)))) / 2`` with
    ``kappa = K / (k_b h^2)`` (``K``: the two torsion springs in series); the margin is
    ``-V'(rho*) / (k_b d h)`` evaluated with the full geometry at that point: positive means
    the inverted minimum exists (a sufficient condition; near the fold also necessary to second
    order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model.constants import (
    dome_extrema,
    inversion_threshold,
    limiting_layer_stiffness,
    torsion_stiffness,
)
from ..model.design import DesignBatch
from ..model.domain import MAX_UNITS
from ..solvers.lattice import segment_height

__all__ = [
    "GEOMETRIC_OUTPUTS",
    "RigidUnits",
    "compose",
    "rigid_units",
    "state_bits",
    "unit_kinematics",
]

#: Outputs the chain composes exactly from its per-unit quantities.
GEOMETRIC_OUTPUTS = ("tip_x", "tip_y", "bend_angle", "curvature")
#: Newton of the rigid unit cell: largest step (rad), step tolerance (rad), iterations.
MAX_STEP = 0.05
STEP_TOL = 1e-13
MAX_ITER = 30
#: Gradient tolerance of a converged unit, relative to the dome's torque scale k_b d h.
GRAD_RTOL = 1e-9
#: Largest start extension of an inverted dome, as a fraction of h (keeps asin defined).
START_CAP = 0.95


def state_bits(requested: NDArray[np.integer], n_units: NDArray[np.integer]) -> NDArray[np.bool_]:
    """Inverted units of requested states, unit 1 (most significant bit) first.

    Returns
    -------
    ndarray of bool, shape (n, MAX_UNITS)
        False beyond each design's N.
    """
    requested = np.asarray(requested, dtype=np.int64)
    n_units = np.asarray(n_units, dtype=np.int64)
    k = np.arange(1, MAX_UNITS + 1)[None, :]
    shift = np.clip(n_units[:, None] - k, 0, None)
    return ((requested[:, None] >> shift) & 1).astype(bool) & (k <= n_units[:, None])


def _nodes(x: NDArray, n_units: NDArray, p1: NDArray, h: NDArray) -> tuple[NDArray, NDArray]:
    """Dome-line and layer nodes ``D_0..D_M``, ``L_0..L_M`` of free coordinates (NaN past N)."""
    rows = x.shape[0]
    M = MAX_UNITS
    D = np.full((rows, M + 1, 2), np.nan)
    L = np.full((rows, M + 1, 2), np.nan)
    D[:, 0] = 0.0
    L[:, 0, 0], L[:, 0, 1] = 0.0, h
    L[:, 1, 0], L[:, 1, 1] = p1, h
    D[:, 1] = x[:, 0:2]
    for k in range(2, M + 1):
        rows_k = n_units >= k
        D[rows_k, k] = x[rows_k, 4 * k - 6 : 4 * k - 4]
        L[rows_k, k] = x[rows_k, 4 * k - 4 : 4 * k - 2]
    return D, L


def _angle(a: NDArray, b: NDArray) -> NDArray:
    """Signed angle from vectors ``a`` to ``b`` (last axis: x, y), in (-pi, pi]."""
    return np.arctan2(
        a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]
    )


def unit_kinematics(
    x: NDArray, n_units: NDArray[np.integer], p1: NDArray, h: NDArray
) -> tuple[NDArray, NDArray, NDArray]:
    """Exact per-unit quantities ``rho, beta, ell`` of shapes (see the module docstring).

    Parameters
    ----------
    x : ndarray of shape (n, >= 4 max(N) - 2), mm
        Free coordinates (``solve_batch(..., shapes=True)["x"]``).
    n_units : ndarray of int, shape (n,)
    p1 : ndarray of shape (n,), mm
        First unit's segment length (``L_1 = (p1, h)`` is clamped).
    h : ndarray of shape (n,), mm
        Segment height.

    Returns
    -------
    rho, beta, ell : ndarrays of shape (n, MAX_UNITS)
        rad, rad, mm; NaN beyond each design's N.
    """
    n_units = np.asarray(n_units, dtype=np.int64)
    D, L = _nodes(np.asarray(x, dtype=float), n_units, np.asarray(p1, float), np.asarray(h, float))
    post = L - D
    rho = _angle(post[:, :-1], post[:, 1:])
    normal = np.stack([post[..., 1], -post[..., 0]], axis=-1)
    segment = L[:, 1:] - L[:, :-1]
    beta = _angle(normal[:, :-1], segment)
    ell = np.hypot(segment[..., 0], segment[..., 1])
    return rho, beta, ell


def compose(
    rho: NDArray, beta: NDArray, ell: NDArray, n_units: NDArray[np.integer], h: NDArray
) -> dict[str, NDArray]:
    """Tip, bend angle and curvature of shapes given per unit (exact kinematics).

    Parameters
    ----------
    rho, beta, ell : ndarrays of shape (n, >= max(N))
        Per-unit quantities (values beyond a design's N are ignored).
    n_units : ndarray of int, shape (n,)
    h : ndarray of shape (n,), mm

    Returns
    -------
    dict
        ``tip_x``, ``tip_y`` (mm), ``bend_angle`` (rad: heading of the last layer segment),
        ``curvature`` (1/mm: bend angle over the layer's length), each of shape (n,).
    """
    n_units = np.asarray(n_units, dtype=np.int64)
    width = rho.shape[1]
    active = np.arange(width)[None, :] < n_units[:, None]
    rho = np.where(active, rho, 0.0)
    psi = np.cumsum(rho, axis=1)
    theta = np.where(active, psi - rho + np.where(active, beta, 0.0), 0.0)
    ell = np.where(active, ell, 0.0)
    rows = np.arange(n_units.size)
    bend = theta[rows, np.clip(n_units - 1, 0, width - 1)]
    length = ell.sum(axis=1)
    return {
        "tip_x": (ell * np.cos(theta)).sum(axis=1),
        "tip_y": np.asarray(h, dtype=float) + (ell * np.sin(theta)).sum(axis=1),
        "bend_angle": bend,
        "curvature": bend / length,
    }


@dataclass(frozen=True)
class RigidUnits:
    """The rigid unit-cell model of every unit of a batch, one entry per unit.

    Units are listed design by design, unit 1 first (the order of ``numpy.nonzero`` on the
    ``(n, MAX_UNITS)`` grid of units); :meth:`grid` puts a field back on that grid.

    Attributes
    ----------
    design, unit : ndarray of int, shape (m,)
        Row of the unit's design in the batch, and ``k - 1``.
    n_designs : int
    rho, beta : ndarray, rad
        Minimum of the unit's energy on its requested side.
    u : ndarray
        Dome extension over reach ``u = (|D_k| - p) / d`` there.
    holds : ndarray of bool
        That minimum exists: converged, positive definite and on the requested side of the
        inversion threshold.
    margin : ndarray
        Holding margin of inverted units (module docstring; positive: holds), ``+inf`` for
        units requested flat.
    inverted : ndarray of bool
        The requested side.
    H, U_L, U_sep, p, h, k_b, alpha, d, u_second, k_t, k_lim : ndarray
        The unit's parameters and closed forms (MODEL.md §2-§4): mm, mm, mm, mm, mm, N/mm, -,
        mm, - (isolated inverted minimum, 3/4 without one), N·mm/rad, N/mm.
    t, t_lim : ndarray
        The unit's design's shared thicknesses (mm).
    """

    design: NDArray
    unit: NDArray
    n_designs: int
    rho: NDArray
    beta: NDArray
    u: NDArray
    holds: NDArray
    margin: NDArray
    inverted: NDArray
    H: NDArray
    U_L: NDArray
    U_sep: NDArray
    p: NDArray
    h: NDArray
    k_b: NDArray
    alpha: NDArray
    d: NDArray
    u_second: NDArray
    k_t: NDArray
    k_lim: NDArray
    t: NDArray
    t_lim: NDArray

    def grid(self, values: NDArray, fill: float = np.nan) -> NDArray:
        """Per-unit ``values`` (shape (m,)) on the ``(n_designs, MAX_UNITS)`` grid."""
        out = np.full((self.n_designs, MAX_UNITS), fill, dtype=float)
        out[self.design, self.unit] = values
        return out


def _derivatives(b, r, p, h, kb, om, d, kp, ko, first):
    """Gradient and Hessian of the unit energy in ``(beta, rho)``; extension ``u``."""
    cb, sb, cr, sr = np.cos(b), np.sin(b), np.cos(r), np.sin(r)
    Dx = p * cb + h * sr
    Dy = h + p * sb - h * cr
    s = np.hypot(Dx, Dy)
    e = s - p
    u = e / d
    f1 = kb * e * (1.0 + om * (2.0 * u * u - 3.0 * u))
    f2 = kb * (1.0 + 6.0 * om * (u * u - u))
    Dbx, Dby = -p * sb, p * cb
    Drx, Dry = h * cr, h * sr
    s_b = (Dx * Dbx + Dy * Dby) / s
    s_r = (Dx * Drx + Dy * Dry) / s
    s_bb = (Dbx * Dbx + Dby * Dby - Dx * p * cb - Dy * p * sb - s_b * s_b) / s
    s_rr = (Drx * Drx + Dry * Dry - Dx * h * sr + Dy * h * cr - s_r * s_r) / s
    s_br = (Dbx * Drx + Dby * Dry - s_b * s_r) / s
    g_b = np.where(first, 0.0, f1 * s_b + kp * b - ko * (r - b))
    g_r = f1 * s_r + ko * (r - b)
    H_bb = np.where(first, 1.0, f2 * s_b * s_b + f1 * s_bb + kp + ko)
    H_rr = f2 * s_r * s_r + f1 * s_rr + ko
    H_br = np.where(first, 0.0, f2 * s_b * s_r + f1 * s_br - ko)
    return g_b, g_r, H_bb, H_br, H_rr, u


def _newton(b, r, args, side):
    """Minimise every unit's energy from ``(b, r)``; steps are damped to MAX_STEP.

    Where the Hessian is not positive definite the step is a push of MAX_STEP in ``rho``
    toward the requested side (``side`` = +1 inverted, -1 flat), which takes a start that
    landed between barrier and fold back into the basin it was meant for.
    """
    b, r = b.copy(), r.copy()
    todo = np.arange(b.size)
    for _ in range(MAX_ITER):
        if todo.size == 0:
            break
        sub = [a[todo] for a in args]
        g_b, g_r, H_bb, H_br, H_rr, _ = _derivatives(b[todo], r[todo], *sub)
        det = H_bb * H_rr - H_br * H_br
        convex = (H_bb > 0.0) & (det > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            db = np.where(convex, -(H_rr * g_b - H_br * g_r) / det, 0.0)
            dr = np.where(convex, -(H_bb * g_r - H_br * g_b) / det, MAX_STEP * side[todo])
        size = np.maximum(np.abs(db), np.abs(dr))
        scale = np.minimum(1.0, MAX_STEP / np.maximum(size, 1e-300))
        b[todo] += scale * db
        r[todo] += scale * dr
        todo = todo[~(size < STEP_TOL) & np.isfinite(size)]
    return b, r


def _unit_constants(batch: DesignBatch, design: NDArray, unit: NDArray) -> dict[str, NDArray]:
    """Closed forms (MODEL.md §3) of the listed units only (not the NaN padding)."""
    shared = {
        name: getattr(batch, name)[design] for name in ("t", "t_lim", "E", "nu", "r_b", "t_ch")
    }
    H, U_L, U_sep = batch.H[design, unit], batch.U_L[design, unit], batch.U_sep[design, unit]
    t, t_ch = shared["t"], shared["t_ch"]
    with np.errstate(all="ignore"):
        springs = batch.constants.springs(H, t, shared["r_b"], shared["E"], U_sep, t_ch)
        return {
            "H": H,
            "U_L": U_L,
            "U_sep": U_sep,
            "t": t,
            "t_lim": shared["t_lim"],
            "p": U_L + t_ch + U_sep,
            "h": segment_height(shared["r_b"], shared["t_lim"], t),
            "k_b": springs["k_b"],
            "alpha": springs["alpha"],
            "d": springs["d"],
            "k_lim": limiting_layer_stiffness(
                shared["E"], shared["t_lim"], shared["r_b"], U_L, t, t_ch
            ),
            "k_t": torsion_stiffness(
                shared["E"], shared["t_lim"], shared["nu"], shared["r_b"], U_sep, t, t_ch
            ),
            "extrema": dome_extrema(springs["alpha"]),
        }


def rigid_units(batch: DesignBatch, inverted: NDArray[np.bool_]) -> RigidUnits:
    """Solve the rigid unit-cell model of every unit of a batch (module docstring).

    Parameters
    ----------
    batch : DesignBatch
        Designs (those with invalid values give NaN or meaningless entries).
    inverted : ndarray of bool, shape (n, MAX_UNITS)
        Requested side of each unit (:func:`state_bits`).

    Returns
    -------
    RigidUnits
    """
    n_units = np.clip(batch.n_units, 0, MAX_UNITS)
    active = np.arange(MAX_UNITS)[None, :] < n_units[:, None]
    design, unit = np.nonzero(active)
    c = _unit_constants(batch, design, unit)
    u_barrier, u_second = c.pop("extrema")
    first = unit == 0
    inv = np.asarray(inverted, dtype=bool)[design, unit]
    # k_t of the unit before: the units of a design are consecutive in this order.
    k_prev = np.where(first, 0.0, np.roll(c["k_t"], 1))
    p, h, kb, alpha, d, ko = (c[name] for name in ("p", "h", "k_b", "alpha", "d", "k_t"))
    om = 1.0 - alpha
    args = (p, h, kb, om, d, k_prev, ko, first)
    with np.errstate(divide="ignore", invalid="ignore"):
        # Series stiffness of the two torsion springs the unit's turn shares (one for unit 1),
        # and the share of the turn taken at the unit's proximal node.
        k_series = np.where(first, ko, k_prev * ko / (k_prev + ko))
        share = np.where(first, 0.0, ko / (k_prev + ko))
        kappa = k_series / (kb * h * h)
        # Linearised inverted minimum and lowest point of V' (module docstring).
        disc_min = 9.0 - 8.0 * (1.0 + kappa) / om
        u_min = np.where(disc_min >= 0.0, (3.0 + np.sqrt(np.abs(disc_min))) / 4.0, 0.75)
        disc_low = 1.0 - 2.0 * (1.0 + kappa) / (3.0 * om)
        u_low = (1.0 + np.sqrt(np.clip(disc_low, 0.0, None))) / 2.0

        def angles_at(u):
            r = np.arcsin(np.clip(u * d / h, 0.0, START_CAP))
            return share * r, r

        b0, r0 = angles_at(u_min)
        b, r = _newton(
            np.where(inv, b0, 0.0), np.where(inv, r0, 0.0), args, np.where(inv, 1.0, -1.0)
        )
        g_b, g_r, H_bb, H_br, H_rr, u = _derivatives(b, r, *args)
        scale = kb * d * h
        converged = np.hypot(g_b, g_r) <= GRAD_RTOL * scale
        convex = (H_bb > 0.0) & (H_bb * H_rr - H_br * H_br > 0.0)
        threshold = inversion_threshold(u_barrier)
        holds = converged & convex & np.where(inv, u > threshold, u < threshold)
        # Margin: -V' at the linearised lowest point, beta slaved by one Schur-complement step.
        bl, rl = angles_at(u_low)
        g_b, g_r, H_bb, H_br, _, _ = _derivatives(bl, rl, *args)
        margin = np.where(inv, -(g_r - H_br * g_b / H_bb) / scale, np.inf)
    return RigidUnits(
        design=design,
        unit=unit,
        n_designs=int(n_units.size),
        rho=r,
        beta=b,
        u=u,
        holds=holds,
        margin=margin,
        inverted=inv,
        u_second=np.where(np.isnan(u_second), 0.75, u_second),
        **{
            name: c[name]
            for name in (
                "H",
                "U_L",
                "U_sep",
                "p",
                "h",
                "k_b",
                "alpha",
                "d",
                "k_t",
                "k_lim",
                "t",
                "t_lim",
            )
        },
    )
