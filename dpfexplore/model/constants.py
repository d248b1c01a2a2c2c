"""Spring constants and isolated-dome analysis (MODEL.md §3-§4), vectorised with NumPy.

Every function broadcasts over its array arguments, so the same code serves one design, one
unit, or a padded ``(n_designs, n_units)`` batch. Lengths in mm, ``E`` in MPa, linear stiffness
in N/mm, torsional stiffness in N·mm/rad, energy in N·mm.

The closed forms are the paper's regressions (eq. kb_model, alpha_model, d_model) with the
coefficients of the authors' implementation, which the paper prints rounded. They were fitted for
5 <= E <= 40 MPa and the paper's unit geometries; :func:`constants_are_valid` flags the results
that are nonsense outside that domain.

Each closed form is written once, as a ``*_form`` function of plain arithmetic (no NumPy calls),
so that the same source serves NumPy arrays here and, on scalars, the Numba kernels that build
the kernel tables, with bit-identical results: the kernels compile the functions listed in
:data:`COMPILED_INLINE` inline (:mod:`dpfexplore._kernels.tables.model_forms`); this module
imports no Numba. Their derivatives with respect to the design parameters
(:func:`constant_derivatives`) are written the same way, for the design sensitivities.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Unit-cell size per dome base radius, ``UC = 3 r_b`` (MODEL.md §2).
UNIT_CELL_PER_BASE_RADIUS = 3.0
#: Dome energy ratio at which the isolated dome loses its second minimum (saddle-node).
ALPHA_BISTABLE = 1.0 / 9.0
#: Dome energy ratio above which the force-extension curve has no dip left: no "ghost" of the
#: lost minimum slows the dome down, so we call it monostable rather than metastable.
ALPHA_GHOST = 1.0 / 3.0
#: The implementation's replacement for a negative dome reach ``d`` (mm).
NO_CONTACT_REACH = 0.01


def dome_radius(H: ArrayLike, r_b: ArrayLike) -> NDArray:
    """Radius of curvature of a spherical cap, ``R = (H² + r_b²) / (2 H)`` in mm."""
    return radius_form(np.asarray(H, dtype=float), np.asarray(r_b, dtype=float))


def radius_form(H, r_b):
    """``R`` of :func:`dome_radius` (plain arithmetic, see the module docstring)."""
    return (H * H + r_b * r_b) / (2.0 * H)


def dome_stiffness(E: ArrayLike, H: ArrayLike, t: ArrayLike, R: ArrayLike) -> NDArray:
    """Linear stiffness ``k_b`` of the dome spring in N/mm (paper eq. kb_model, exactly).

    Parameters
    ----------
    E : array_like, MPa
        Young's modulus.
    H, t, R : array_like, mm
        Dome height, dome thickness and dome radius of curvature.
    """
    E, H, t, R = (np.asarray(a, dtype=float) for a in (E, H, t, R))
    return kb_form(E, H, t, R)


def kb_form(E, H, t, R):
    """``k_b`` of :func:`dome_stiffness` (plain arithmetic)."""
    # Powers by multiplication: ``**`` with float exponents costs a pow() call per entry.
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    H2 = H * H
    R2 = R * R
    poly = (
        -1.97 * R * t5 / (H2 * H)
        + 7.4 * H2 * t3 / R2
        + 3.5 * R * t4 / H2
        + 0.37 * H2 * t2 / R
        + 42.2 * t5 / H2
        - 35.8 * H * t4 / R2
        + 71.8 * t5 / (H * R)
        - 3.4 * R * t3 / H
        - 67.7 * t4 / H
        + 4.2 * R * t2
        + 11.1 * t3
    )
    return E / R2 * poly


def dome_alpha(H: ArrayLike, t: ArrayLike, R: ArrayLike) -> NDArray:
    """Dimensionless energy ratio ``α`` of the dome spring (MODEL.md §3, implementation's digits).

    ``α`` is the inverted-state energy ``E_NL(d)`` over the energy ``½ k_b d²`` a linear spring
    would store at the same extension; the isolated dome is bistable iff ``α < 1/9``.
    """
    H, t, R = (np.asarray(a, dtype=float) for a in (H, t, R))
    return alpha_form(H, t, R)


def alpha_form(H, t, R):
    """``α`` of :func:`dome_alpha` (plain arithmetic)."""
    H2 = H * H
    H3 = H2 * H
    R2 = R * R
    R3 = R2 * R
    t2 = t * t
    t3 = t2 * t
    return (
        0.3823 * H3 / R3
        - 0.5736 * t3 / H3
        - 2.8677 * H2 * t / R3
        - 0.9559 * H2 / R2
        - 8.9853 * t3 / (H2 * R)
        + 1.5295 * t2 / H2
        - 4.0147 * t3 / (H * R2)
        + 9.1764 * H * t / R2
        + 17.3971 * t2 / (H * R)
        + 0.5736 * H / R
        + 17.7795 * t3 / R3
        - 19.5 * t2 / R2
        - 6.1177 * t / R
    )


def dome_reach(
    H: ArrayLike, t: ArrayLike, U_sep: ArrayLike, t_ch: ArrayLike
) -> tuple[NDArray, NDArray]:
    """Extension ``d`` (mm) at which the inverted dome meets the next unit's chamber wall.

    ``d = (0.2565 t + 2.1425 H) - H - U_sep - t_ch/2 - t/2`` (paper eq. d_model with the
    implementation's digits). Where that is not positive the dome cannot reach the wall; the
    implementation then uses ``d = 0.01``, which we keep for comparability while flagging it.

    Returns
    -------
    d : ndarray, mm
        Reach used by the model (``NO_CONTACT_REACH`` where clamped).
    no_contact : ndarray of bool
        True where the closed form gave ``d <= 0`` and was clamped: such a dome cannot bend the
        finger.
    """
    H, t, U_sep, t_ch = (np.asarray(a, dtype=float) for a in (H, t, U_sep, t_ch))
    raw = reach_raw_form(H, t, U_sep, t_ch)
    # d == 0 exactly would divide by zero in u = x/d, so it is clamped along with d < 0.
    no_contact = raw <= 0.0
    return np.where(no_contact, NO_CONTACT_REACH, raw), no_contact


#: The inverted apex travel ``tip_dis = TIP_PER_THICKNESS t + TIP_PER_HEIGHT H`` (paper eq.
#: d_model, the implementation's digits).
TIP_PER_THICKNESS = 0.2565
TIP_PER_HEIGHT = 2.1425


def reach_raw_form(H, t, U_sep, t_ch):
    """The closed form of ``d`` before the clamp (mm)."""
    return (TIP_PER_THICKNESS * t + TIP_PER_HEIGHT * H) - H - U_sep - t_ch / 2.0 - t / 2.0


def limiting_layer_stiffness(
    E: ArrayLike, t_lim: ArrayLike, r_b: ArrayLike, U_L: ArrayLike, t: ArrayLike, t_ch: ArrayLike
) -> NDArray:
    """Axial stiffness of a limiting-layer segment, ``k_lim = E t_lim UC / (U_L + t + t_ch)``, N/mm.

    The denominator is the implementation's; the paper's text writes ``U_L`` alone.
    """
    E, t_lim, r_b, U_L, t, t_ch = (np.asarray(a, float) for a in (E, t_lim, r_b, U_L, t, t_ch))
    return k_lim_form(E, t_lim, r_b, U_L, t, t_ch)


def k_lim_form(E, t_lim, r_b, U_L, t, t_ch):
    """``k_lim`` of :func:`limiting_layer_stiffness` (plain arithmetic)."""
    return E * t_lim * (UNIT_CELL_PER_BASE_RADIUS * r_b) / (U_L + t + t_ch)


#: Posts (chamber walls) are this many times stiffer than the limiting layer of their unit.
POST_STIFFNESS_FACTOR = 5.0


def torsion_stiffness(
    E: ArrayLike,
    t_lim: ArrayLike,
    nu: ArrayLike,
    r_b: ArrayLike,
    U_sep: ArrayLike,
    t: ArrayLike,
    t_ch: ArrayLike,
) -> NDArray:
    """Bending stiffness of the limiting layer at a node, N·mm/rad.

    ``k_t = E t_lim³ / (12 (1 - ν²)) · UC / (U_sep + t + t_ch)``; the denominator is the
    implementation's (the paper's text writes ``U_sep`` alone).
    """
    args = (np.asarray(a, float) for a in (E, t_lim, nu, r_b, U_sep, t, t_ch))
    return k_t_form(*args)


def k_t_form(E, t_lim, nu, r_b, U_sep, t, t_ch):
    """``k_t`` of :func:`torsion_stiffness` (plain arithmetic)."""
    # t_lim³ by multiplication, not ``**``: NumPy's and libm's pow differ in the last bit.
    plate = E * (t_lim * t_lim * t_lim) / (12.0 * (1.0 - nu * nu))
    return plate * (UNIT_CELL_PER_BASE_RADIUS * r_b) / (U_sep + t + t_ch)


def segment_height(r_b: ArrayLike, t_lim: ArrayLike, t: ArrayLike) -> NDArray:
    """Segment height ``h = UC/2 + t_lim + t`` (mm), the post rest length (MODEL.md §2)."""
    return segment_height_form(*(np.asarray(a, dtype=float) for a in (r_b, t_lim, t)))


def segment_height_form(r_b, t_lim, t):
    """``h`` of :func:`segment_height` (plain arithmetic)."""
    return UNIT_CELL_PER_BASE_RADIUS * r_b / 2.0 + t_lim + t


# The two regressions as monomials ``c · H^a t^b R^e``, term for term those of ``_kb`` (inside
# ``E / R²``) and ``_alpha``, for their partial derivatives: ``∂(c H^a t^b R^e)/∂H = a·term/H``.
_KB_TERMS = (
    (-1.97, -3, 5, 1),
    (7.4, 2, 3, -2),
    (3.5, -2, 4, 1),
    (0.37, 2, 2, -1),
    (42.2, -2, 5, 0),
    (-35.8, 1, 4, -2),
    (71.8, -1, 5, -1),
    (-3.4, -1, 3, 1),
    (-67.7, -1, 4, 0),
    (4.2, 0, 2, 1),
    (11.1, 0, 3, 0),
)
_ALPHA_TERMS = (
    (0.3823, 3, 0, -3),
    (-0.5736, -3, 3, 0),
    (-2.8677, 2, 1, -3),
    (-0.9559, 2, 0, -2),
    (-8.9853, -2, 3, -1),
    (1.5295, -2, 2, 0),
    (-4.0147, -1, 3, -2),
    (9.1764, 1, 1, -2),
    (17.3971, -1, 2, -1),
    (0.5736, 1, 0, -1),
    (17.7795, 0, 3, -3),
    (-19.5, 0, 2, -2),
    (-6.1177, 0, 1, -1),
)
#: ``∂d/∂H`` and ``∂d/∂t`` of the unclamped reach (``∂d/∂U_sep = -1``).
REACH_PER_HEIGHT = 2.1425 - 1.0
REACH_PER_THICKNESS = 0.2565 - 0.5


def _ipow(x, n):
    """``x**n`` for a small integer ``n`` by multiplication (identical in NumPy and Numba)."""
    result = 1.0 + 0.0 * x
    base = x if n >= 0 else 1.0 / x
    for _ in range(abs(n)):
        result = result * base
    return result


def _monomial_partials(terms, H, t, R):
    """Partial derivatives in ``H``, ``t`` and ``R`` of ``Σ c H^a t^b R^e`` over ``terms``."""
    d_H = 0.0 * H
    d_t = 0.0 * H
    d_R = 0.0 * H
    for c, a, b, e in terms:
        m = c * _ipow(H, a) * _ipow(t, b) * _ipow(R, e)
        d_H = d_H + a * m / H
        d_t = d_t + b * m / t
        d_R = d_R + e * m / R
    return d_H, d_t, d_R


def constant_derivatives_form(H, U_L, U_sep, shared):
    """Derivatives of a unit's constants in its design parameters (the chain of MODEL.md §3).

    ``H``, ``U_L``, ``U_sep``: the unit's (mm); ``shared``: the design's ``(t, t_lim, E, nu,
    r_b, t_ch)`` (mm, MPa), a tuple (``SharedParams`` in the kernels).

    Returns the tuple ``(dR_dH, dkb_dH, dkb_dt, dalpha_dH, dalpha_dt, dd_dH, dd_dt, dd_dUsep,
    dklim_dUL, dklim_dt, dklim_dtlim, dkt_dUsep, dkt_dt, dkt_dtlim)``; every other derivative
    of ``p, k_b, α, d, k_lim, k_t`` in ``H, U_L, U_sep, t, t_lim`` is 0 or 1 (``dp/dU_L =
    dp/dU_sep = 1``) and every stiffness is proportional to ``E``. Where ``d`` is clamped
    (``no_contact``) it is the constant ``NO_CONTACT_REACH``, so its derivatives are 0 there.
    """
    t, t_lim, E, nu, r_b, t_ch = shared
    R = radius_form(H, r_b)
    dR_dH = 0.5 - r_b * r_b / (2.0 * H * H)
    scale = E / (R * R)
    kb = kb_form(E, H, t, R)
    p_H, p_t, p_R = _monomial_partials(_KB_TERMS, H, t, R)
    dkb_dH = scale * (p_H + p_R * dR_dH) - 2.0 * kb / R * dR_dH
    dkb_dt = scale * p_t
    a_H, a_t, a_R = _monomial_partials(_ALPHA_TERMS, H, t, R)
    dalpha_dH = a_H + a_R * dR_dH
    dalpha_dt = a_t
    contact = 1.0 * (reach_raw_form(H, t, U_sep, t_ch) > 0.0)
    dd_dH = REACH_PER_HEIGHT * contact
    dd_dt = REACH_PER_THICKNESS * contact
    dd_dUsep = -1.0 * contact
    k_lim = k_lim_form(E, t_lim, r_b, U_L, t, t_ch)
    dklim_dUL = -k_lim / (U_L + t + t_ch)
    dklim_dtlim = k_lim / t_lim
    k_t = k_t_form(E, t_lim, nu, r_b, U_sep, t, t_ch)
    dkt_dUsep = -k_t / (U_sep + t + t_ch)
    dkt_dtlim = 3.0 * k_t / t_lim
    return (
        dR_dH,
        dkb_dH,
        dkb_dt,
        dalpha_dH,
        dalpha_dt,
        dd_dH,
        dd_dt,
        dd_dUsep,
        dklim_dUL,
        dklim_dUL,
        dklim_dtlim,
        dkt_dUsep,
        dkt_dUsep,
        dkt_dtlim,
    )


#: The functions of this module that the kernels compile inline
#: (:mod:`dpfexplore._kernels.tables.model_forms`): plain arithmetic on scalars or arrays, calling
#: only each other.
COMPILED_INLINE = (
    radius_form,
    kb_form,
    alpha_form,
    reach_raw_form,
    k_lim_form,
    k_t_form,
    segment_height_form,
    _ipow,
    _monomial_partials,
    constant_derivatives_form,
)

#: Parameters of :func:`constant_derivatives`, in the order of the sensitivities.
DERIVATIVE_PARAMETERS = ("H", "U_L", "U_sep", "t", "t_lim")


def constant_derivatives(
    H: ArrayLike,
    U_L: ArrayLike,
    U_sep: ArrayLike,
    t: ArrayLike,
    t_lim: ArrayLike,
    E: ArrayLike,
    nu: ArrayLike,
    r_b: ArrayLike,
    t_ch: ArrayLike,
) -> dict[str, dict[str, NDArray]]:
    """Analytic derivatives of a unit's constants in its design parameters (vectorised).

    The chain through the closed forms of MODEL.md §3: ``R(H)``, ``k_b(E, H, t, R)``,
    ``α(H, t, R)``, ``d(H, t, U_sep)``, ``k_lim(E, t_lim, U_L, t)``, ``k_post = 5 k_lim``,
    ``k_t(E, t_lim, U_sep, t)``, ``p = U_L + t_ch + U_sep`` and ``h = UC/2 + t_lim + t``.
    Where the closed form gives ``d <= 0`` the model uses the constant ``d = 0.01`` mm
    (``no_contact``), so the derivatives of ``d`` are 0 there: one-sided, on the branch in use
    (at ``d = 0`` exactly, the clamped one). ``E`` is not listed: every stiffness is
    proportional to it and nothing else depends on it.

    Returns
    -------
    dict
        ``result[constant][parameter]`` for constants ``"R", "k_b", "alpha", "d", "k_lim",
        "k_post", "k_t", "p", "h"`` and parameters :data:`DERIVATIVE_PARAMETERS`, each an array
        broadcast over the arguments (units: the constant's per the parameter's, e.g. N/mm²
        for ``k_b`` per mm of ``H``). Entries that are identically zero are zero arrays.
    """
    args = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (H, U_L, U_sep, t, t_lim, E, nu, r_b, t_ch))
    )
    with np.errstate(all="ignore"):
        (
            dR_dH,
            dkb_dH,
            dkb_dt,
            dalpha_dH,
            dalpha_dt,
            dd_dH,
            dd_dt,
            dd_dUsep,
            dklim_dUL,
            dklim_dt,
            dklim_dtlim,
            dkt_dUsep,
            dkt_dt,
            dkt_dtlim,
        ) = constant_derivatives_form(*args[:3], tuple(args[3:]))
    zero = np.zeros(args[0].shape)
    one = np.ones(args[0].shape)
    table = {
        "R": {"H": dR_dH},
        "k_b": {"H": dkb_dH, "t": dkb_dt},
        "alpha": {"H": dalpha_dH, "t": dalpha_dt},
        "d": {"H": dd_dH, "t": dd_dt, "U_sep": dd_dUsep},
        "k_lim": {"U_L": dklim_dUL, "t": dklim_dt, "t_lim": dklim_dtlim},
        "k_post": {
            "U_L": POST_STIFFNESS_FACTOR * dklim_dUL,
            "t": POST_STIFFNESS_FACTOR * dklim_dt,
            "t_lim": POST_STIFFNESS_FACTOR * dklim_dtlim,
        },
        "k_t": {"U_sep": dkt_dUsep, "t": dkt_dt, "t_lim": dkt_dtlim},
        "p": {"U_L": one, "U_sep": one},
        "h": {"t": one, "t_lim": one},
    }
    return {
        name: {param: partials.get(param, zero) for param in DERIVATIVE_PARAMETERS}
        for name, partials in table.items()
    }


def constants_are_valid(k_b: ArrayLike, alpha: ArrayLike) -> NDArray:
    """Where the closed forms describe a physical dome.

    ``k_b <= 0`` is not a spring; ``α >= 1`` makes the quartic dome energy unbounded below;
    ``α <= 0`` makes the inverted state at least as cheap as the flat, stress-free dome. All three
    happen only outside the fitted domain (thin layers of very thick, very shallow domes).
    """
    k_b = np.asarray(k_b, dtype=float)
    alpha = np.asarray(alpha, dtype=float)
    return np.isfinite(k_b) & np.isfinite(alpha) & (k_b > 0.0) & (alpha > 0.0) & (alpha < 1.0)


@dataclass(frozen=True)
class DomeAnalysis:
    """Isolated-dome landscape of the bistable spring (MODEL.md §4), one entry per dome.

    Extensions are in units of the reach ``d`` (``u = x̄ / d``). Entries that do not exist for a
    dome's regime are NaN (a monostable dome has no barrier).

    Attributes
    ----------
    regime : ndarray of str
        ``"bistable"`` (``α < 1/9``: a second minimum exists), ``"metastable"``
        (``1/9 <= α < 1/3``: no second minimum, but the force dips, so the dome creeps back
        slowly through the ghost of the lost minimum) or ``"monostable"`` (``α >= 1/3``: the
        restoring force grows monotonically). This is the isolated dome's static regime; the
        class of a unit inside its finger comes from the dynamics (MODEL.md §8).
    u_barrier : ndarray
        Energy maximum between the two minima, ``(3 - √((1-9α)/(1-α)))/4``.
    u_second_min : ndarray
        The inverted minimum, ``(3 + √((1-9α)/(1-α)))/4``.
    u_inversion : ndarray
        Threshold past which a unit counts as inverted: ``u_barrier`` where it exists, else 3/4
        (MODEL.md §6).
    barrier_energy, second_min_energy : ndarray, N·mm
        Dome energy at the barrier and at the second minimum.
    peak_force : ndarray, N
        Largest restoring force before the snap, ``max f'(x̄)`` on the rising branch (the force
        needed to push the dome through); NaN for monostable domes, whose force never peaks.
    peak_u : ndarray
        Where the force peaks.
    """

    regime: NDArray
    u_barrier: NDArray
    u_second_min: NDArray
    u_inversion: NDArray
    barrier_energy: NDArray
    second_min_energy: NDArray
    peak_force: NDArray
    peak_u: NDArray


def dome_energy(x_bar: ArrayLike, k_b: ArrayLike, alpha: ArrayLike, d: ArrayLike) -> NDArray:
    """Dome spring energy ``½ k_b x̄² (1 + (1-α)(u² - 2u))`` in N·mm, ``u = x̄/d``."""
    x_bar = np.asarray(x_bar, dtype=float)
    u = x_bar / np.asarray(d, dtype=float)
    return (
        0.5
        * np.asarray(k_b, float)
        * x_bar**2
        * (1.0 + (1.0 - np.asarray(alpha)) * (u * u - 2 * u))
    )


def dome_force(x_bar: ArrayLike, k_b: ArrayLike, alpha: ArrayLike, d: ArrayLike) -> NDArray:
    """Dome spring force ``k_b x̄ (1 + (1-α)(2u² - 3u))`` in N (derivative of the energy)."""
    x_bar = np.asarray(x_bar, dtype=float)
    u = x_bar / np.asarray(d, dtype=float)
    return np.asarray(k_b, float) * x_bar * (1.0 + (1.0 - np.asarray(alpha)) * (2 * u * u - 3 * u))


#: Inversion threshold ``u`` of a dome without a barrier (MODEL.md §6).
U_INVERSION_WITHOUT_BARRIER = 0.75


def inversion_threshold(u_barrier: ArrayLike) -> NDArray:
    """Extension past which a unit counts as inverted: its barrier, or 3/4 without one."""
    u_barrier = np.asarray(u_barrier, dtype=float)
    return np.where(np.isnan(u_barrier), U_INVERSION_WITHOUT_BARRIER, u_barrier)


def dome_extrema(alpha: ArrayLike) -> tuple[NDArray, NDArray]:
    """Barrier and inverted minimum of isolated domes, ``u = (3 ∓ √((1-9α)/(1-α)))/4``.

    NaN where the dome is not bistable (``α >= 1/9``). The part of :func:`analyse_domes` the
    kernels need, without the energies and forces.
    """
    alpha = np.asarray(alpha, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = (1.0 - 9.0 * alpha) / (1.0 - alpha)
        root = np.sqrt(np.where(alpha < ALPHA_BISTABLE, disc, np.nan))
    return (3.0 - root) / 4.0, (3.0 + root) / 4.0


def analyse_domes(k_b: ArrayLike, alpha: ArrayLike, d: ArrayLike) -> DomeAnalysis:
    """Regime, barrier, second minimum and peak force of isolated domes (vectorised).

    Parameters
    ----------
    k_b : array_like, N/mm
    alpha : array_like
    d : array_like, mm
    """
    k_b, alpha, d = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (k_b, alpha, d)))
    one_minus = 1.0 - alpha
    bistable = alpha < ALPHA_BISTABLE
    u_barrier, u_second = dome_extrema(alpha)
    with np.errstate(invalid="ignore", divide="ignore"):
        # f''(u) = k_b (1 + 6 (1-α)(u² - u)) vanishes at u = (1 ∓ √(1 - 2/(3(1-α))))/2.
        has_peak = alpha < ALPHA_GHOST
        peak_u = (1.0 - np.sqrt(np.where(has_peak, 1.0 - 2.0 / (3.0 * one_minus), np.nan))) / 2.0
    regime = np.where(bistable, "bistable", np.where(has_peak, "metastable", "monostable"))
    return DomeAnalysis(
        regime=regime,
        u_barrier=u_barrier,
        u_second_min=u_second,
        u_inversion=inversion_threshold(u_barrier),
        barrier_energy=dome_energy(u_barrier * d, k_b, alpha, d),
        second_min_energy=dome_energy(u_second * d, k_b, alpha, d),
        peak_force=dome_force(peak_u * d, k_b, alpha, d),
        peak_u=peak_u,
    )
