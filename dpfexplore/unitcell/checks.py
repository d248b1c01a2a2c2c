"""Closed forms the shell model is checked against (MODEL.md §11).

* :func:`plate_stiffness`: a simply supported (pinned) circular plate under a central point load
  (Timoshenko & Woinowsky-Krieger, *Theory of Plates and Shells*, §19):
  ``w(0) = P r_b² (3 + ν) / (16 π D (1 + ν))``.
* :func:`shallow_shell_stiffness`: Reissner's point-loaded shallow spherical shell, far from its
  edge (E. Reissner, "Stresses and small displacements of shallow spherical shells", J. Math.
  Phys. 25, 1946): ``k = 4 E t² / (R √(3 (1 - ν²)))``, valid when the base radius spans many
  bending lengths :func:`bending_length`.
* :func:`pinned_shallow_cap_stiffness`: the same shallow-shell equations solved exactly for a
  *finite* cap of base radius ``r_b`` with a pinned, immovable edge (Kelvin functions). A pinned
  edge stiffens the cap by ``≈ 4 (1 + ν) ℓ² / (π r_b²)`` for large ``r_b / ℓ`` (the point load's
  membrane far field decays only algebraically): +3.0 % at ``r_b = 8 ℓ``, +1.9 % at ``10 ℓ``,
  +0.45 % at ``20 ℓ``; within 2 % of Reissner's value from ``r_b = 9.76 ℓ`` on
  (``docs/guide/unitcell.md``).
* :func:`ridge_exponent`: the exponent of ``F ∝ δ^n`` fitted on the first branch of a path;
  Pogorelov's mirror-buckling ridge (Pogorelov 1988) gives ``n = 1/2`` for thin deep caps once the
  travel is many thicknesses.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy import special

if TYPE_CHECKING:
    from .shell import UnitCellRun

__all__ = [
    "bending_length",
    "pinned_shallow_cap_stiffness",
    "plate_stiffness",
    "ridge_exponent",
    "shallow_shell_stiffness",
]


def plate_stiffness(E: float, nu: float, t: float, r_b: float) -> float:
    """Central point-load stiffness (N/mm) of a pinned circular plate of radius ``r_b`` (mm)."""
    D = E * t**3 / (12.0 * (1.0 - nu**2))
    return 16.0 * math.pi * D * (1.0 + nu) / ((3.0 + nu) * r_b**2)


def shallow_shell_stiffness(E: float, nu: float, t: float, R: float) -> float:
    """Reissner's point-load stiffness (N/mm) of a shallow spherical shell of radius ``R`` (mm)."""
    return 4.0 * E * t**2 / (R * math.sqrt(3.0 * (1.0 - nu**2)))


def bending_length(R: float, t: float, nu: float) -> float:
    """Bending length ``ℓ = √(R t) / (12 (1 - ν²))^{1/4}`` (mm) of a spherical shell."""
    return math.sqrt(R * t) / (12.0 * (1.0 - nu**2)) ** 0.25


def pinned_shallow_cap_stiffness(E: float, nu: float, t: float, R: float, r_b: float) -> float:
    """Central point-load stiffness (N/mm) of a finite, pinned, shallow spherical cap.

    The exact linear solution of the axisymmetric shallow-shell (Marguerre / Reissner 1946)
    equations for a cap of sphere radius ``R`` and base radius ``r_b``, pinned and immovable at
    its edge, under a point load at the apex.

    Parameters
    ----------
    E : float
        Young's modulus (MPa).
    nu : float
        Poisson's ratio, ``-1 < nu < 0.5``.
    t : float
        Thickness (mm).
    R : float
        Radius of the sphere (mm); ``math.inf`` gives the flat plate (:func:`plate_stiffness`).
    r_b : float
        Base radius of the cap (mm), at most 800 bending lengths :func:`bending_length` (beyond,
        the Kelvin functions overflow; the cap is then within 3e-6 of
        :func:`shallow_shell_stiffness`).

    Returns
    -------
    float
        ``P / w(0)``: the apex load over the apex deflection relative to the edge (N/mm).

    Notes
    -----
    With ``D = E t³ / (12 (1 - ν²))``, the radial coordinate ``r``, the deflection ``w`` along the
    load, the slope ``θ = w'`` and the stress function ``Φ`` (``N_r = Φ'/r``,
    ``N_θ = Φ''``), the shallow-shell equations ``D ∇⁴w + ∇²Φ / R = p`` and
    ``∇⁴Φ / (E t) - ∇²w / R = 0`` become, after one integration over the disc of radius ``r``
    (vertical equilibrium with the load ``P``) and with the membrane strains ``u' - r w'/R`` and
    ``u / r`` (compatibility), the pair, for ``φ = Φ'``::

        D L[θ] + φ / R = P / (2 π r),     L[φ] = E t θ / R,     L[f] = f'' + f'/r - f/r².

    In ``x = r / ℓ``, ``ℓ`` the bending length (``ℓ⁴ = R² D / (E t)``), and the scaled unknowns
    ``θ = P ℓ / (2 π D) θ̂``, ``φ = P R / (2 π ℓ) φ̂``, the complex ``F = θ̂ + i φ̂`` obeys
    ``L_x[F] - i F = 1 / x``. Its solution regular at the apex is::

        F = i (1/x + ker'(x) + i kei'(x)) + (c₁ + i c₂) (ber'(x) + i bei'(x)),

    Reissner's unbounded-shell solution (``ker' ≈ -1/x`` cancels the ``1/x`` at the apex) plus
    the regular homogeneous one: ``θ̂ = -kei' + c₁ ber' - c₂ bei'`` and
    ``φ̂ = 1/x + ker' + c₁ bei' + c₂ ber'``. The pinned edge ``x_b = r_b / ℓ`` fixes the real
    ``c₁, c₂`` (a 2 × 2 linear system)::

        M_r = 0:   θ̂'(x_b) + ν θ̂(x_b) / x_b = 0,
        u = 0:     x_b φ̂'(x_b) - ν φ̂(x_b) = 0,

    with the second derivatives from the Kelvin equations (``ber'' = -bei - ber'/x``,
    ``bei'' = ber - bei'/x``, the same for ``ker, kei``). The third edge condition ``w(r_b) = 0``
    sets the datum: ``w(0) = -∫₀^{r_b} θ dr`` gives::

        w(0) = P ℓ² / (2 π D) [kei(x_b) + π/4 - c₁ (ber(x_b) - 1) + c₂ bei(x_b)].

    For ``x_b → ∞`` this is Reissner's ``P ℓ² / (8 D)`` (:func:`shallow_shell_stiffness`), for
    ``x_b → 0`` (flat) the pinned plate (:func:`plate_stiffness`); the excess over Reissner's
    value tends to ``4 (1 + ν) / (π x_b²)``. ``tests/unitcell/test_closed_forms.py`` checks the
    formula against a numerical solution of the same boundary-value problem.

    References
    ----------
    E. Reissner, "Stresses and small displacements of shallow spherical shells", I and II,
    J. Math. Phys. 25 (1946-47); K. Marguerre, Proc. 5th Int. Congr. Appl. Mech. (1938), the
    shallow-shell (curved-plate) equations.
    """
    D = E * t**3 / (12.0 * (1.0 - nu**2))
    if math.isinf(R):
        return plate_stiffness(E, nu, t, r_b)
    ell = bending_length(R, t, nu)
    x = r_b / ell
    if x > 800.0:
        raise ValueError(
            f"r_b={r_b!r}: more than 800 bending lengths ({ell:.4g} mm); use "
            "shallow_shell_stiffness (within 3e-6)"
        )
    if x < 1e-3:  # flat to within ~0.09 x⁴ < 1e-13; the Kelvin sums would cancel digits here
        return plate_stiffness(E, nu, t, r_b)
    ber, bei, ker, kei = special.ber(x), special.bei(x), special.ker(x), special.kei(x)
    berp, beip = special.berp(x), special.beip(x)
    kerp, keip = special.kerp(x), special.keip(x)
    berpp, beipp = -bei - berp / x, ber - beip / x
    kerpp, keipp = -kei - kerp / x, ker - keip / x
    matrix = np.array(
        [
            [berpp + nu * berp / x, -(beipp + nu * beip / x)],
            [x * beipp - nu * beip, x * berpp - nu * berp],
        ]
    )
    rhs = np.array(
        [
            keipp + nu * keip / x,
            -(x * (kerpp - 1.0 / x**2) - nu * (1.0 / x + kerp)),
        ]
    )
    c1, c2 = np.linalg.solve(matrix, rhs)
    w_hat = kei + 0.25 * math.pi - c1 * (ber - 1.0) + c2 * bei
    return float(2.0 * math.pi * D / (ell**2 * w_hat))


def ridge_exponent(run: UnitCellRun, low: float = 20.0, high: float = 80.0) -> tuple[float, int]:
    """Exponent ``n`` of ``F ∝ δ^n`` on the first branch for ``low t <= δ <= high t``.

    Returns the least-squares slope of ``log F`` against ``log δ`` and the number of points it
    used (at least 5, else ``ValueError``).
    """
    first = run.branch == 0
    d, f = run.displacement[first], run.force[first]
    window = (d >= low * run.t) & (d <= high * run.t) & (f > 0.0)
    if window.sum() < 5:
        raise ValueError(
            f"low={low}, high={high}: fewer than 5 points of the first branch in that window"
        )
    slope = np.polyfit(np.log(d[window]), np.log(f[window]), 1)[0]
    return float(slope), int(window.sum())
