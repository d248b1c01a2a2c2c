"""Closed forms the shell model is checked against (MODEL.md §11, issue 21 §3).

* :func:`plate_stiffness`: a simply supported (pinned) circular plate under a central point load
  (Timoshenko & Woinowsky-Krieger, *Theory of Plates and Shells*, §19):
  ``w(0) = P r_b² (3 + ν) / (16 π D (1 + ν))``.
* :func:`shallow_shell_stiffness`: Reissner's point-loaded shallow spherical shell, far from its
  edge (E. Reissner, "Stresses and small displacements of shallow spherical shells", J. Math.
  Phys. 25, 1946): ``k = 4 E t² / (R √(3 (1 - ν²)))``, valid when the base radius spans many
  bending lengths :func:`bending_length`. A pinned (immovable) edge stiffens a finite cap: the
  membrane far field of the point load decays only algebraically, so the shell model exceeds
  Reissner's value by about 2.9 % at ``r_b = 8 ℓ``, 1.8 % at ``10 ℓ`` and 0.3 % at ``20 ℓ``
  (``docs/guide/unitcell.md``).
* :func:`ridge_exponent`: the exponent of ``F ∝ δ^n`` fitted on the first branch of a path;
  Pogorelov's mirror-buckling ridge (Pogorelov 1988) gives ``n = 1/2`` for thin deep caps once the
  travel is many thicknesses.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .shell import UnitCellRun

__all__ = ["bending_length", "plate_stiffness", "ridge_exponent", "shallow_shell_stiffness"]


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
