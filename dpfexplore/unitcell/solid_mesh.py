"""The meridional section of a dome as 9-node quadrilaterals (for :mod:`.solid_check`).

A structured grid in (mid-surface arclength ``s``, distance ``ζ`` from the mid-surface) mapped
exactly onto the cap: ``R = (1 + κ ζ) sin(κ s)/κ``, ``Z = H + ζ cos(κ s) − 2 sin²(κ s/2)/κ`` with
``κ = 1/R_mid`` (MODEL.md §2), written so that shallow caps and the flat plate (``κ = 0``) lose
no precision. The apex column ``s ≤ a`` is bounded by a mesh line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from skfem import MeshQuad, MeshQuad2

__all__ = ["MeshSpec", "dome_mesh"]


@dataclass(frozen=True)
class MeshSpec:
    """A structured mesh of the meridional section.

    Attributes
    ----------
    n_along : int
        Elements along the meridian outside the apex column.
    n_through : int
        Elements through the thickness (even: the mid-surface is a mesh line).
    n_disc : int
        Elements along the meridian inside the apex column (``s ≤ a``).
    grading : float
        Largest ratio of neighbouring element lengths along the meridian: sizes grow
        geometrically from the column's toward the edge (1: uniform), to refine where the apex
        bending is concentrated.
    """

    n_along: int = 40
    n_through: int = 4
    n_disc: int = 2
    grading: float = 1.1

    def refined(self) -> MeshSpec:
        """Every element halved in both directions."""
        return MeshSpec(2 * self.n_along, 2 * self.n_through, 2 * self.n_disc, self.grading)


def _curvature_terms(kappa: float, s: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """``sin φ / κ``, ``(1 − cos φ)/κ`` and ``cos φ`` for ``φ = κ s``, exact as ``κ → 0`` (mm)."""
    if kappa == 0.0:
        return s.copy(), np.zeros_like(s), np.ones_like(s)
    phi = kappa * s
    # 2 sin²(φ/2) rather than 1 − cos φ: no cancellation for shallow caps
    return np.sin(phi) / kappa, 2.0 * np.sin(0.5 * phi) ** 2 / kappa, np.cos(phi)


def _graded(length: float, spec: MeshSpec, a: float) -> NDArray:
    """Node positions (mm) past the column: sizes growing geometrically from the column's.

    The first element is as long as the column's (``a / n_disc``) unless a uniform division is
    finer, so the prescribed column never meets a much smaller element; the ratio is capped at
    ``spec.grading``.
    """
    n, h0 = spec.n_along, a / spec.n_disc
    if length / n <= h0 or spec.grading <= 1.0:
        return np.linspace(0.0, length, n + 1)[1:]
    lo, hi = 1.0, spec.grading
    if h0 * (hi**n - 1.0) / (hi - 1.0) < length:
        q = hi  # the cap binds: start larger than h0
        h0 = length * (q - 1.0) / (q**n - 1.0)
    else:
        for _ in range(200):  # bisection on the ratio q: h0 (qⁿ − 1)/(q − 1) = length
            q = 0.5 * (lo + hi)
            lo, hi = (q, hi) if h0 * (q**n - 1.0) / (q - 1.0) < length else (lo, q)
        q = 0.5 * (lo + hi)
    sizes = h0 * q ** np.arange(n)
    return np.cumsum(sizes * (length / sizes.sum()))


def dome_mesh(
    H: float, t: float, r_b: float, spec: MeshSpec, a: float
) -> tuple[MeshQuad2, MeshQuad2, float]:
    """The cap's meridional section as quadratic quadrilaterals.

    Parameters
    ----------
    H, t, r_b : float, mm
        Dome height, thickness and base radius of the mid-surface (``H = 0``: flat plate).
    spec : MeshSpec
    a : float, mm
        Mid-surface arclength of the apex column (a mesh line).

    Returns
    -------
    mesh : MeshQuad2
        Physical coordinates ``(R, Z)``, mm.
    param : MeshQuad2
        The same topology in the parameters ``(s, ζ)``, mm, for selecting dofs and facets.
    s_b : float, mm
        Mid-surface arclength from apex to edge.
    """
    kappa = 2.0 * H / (r_b**2 + H**2)
    # tan(φ_b / 2) = H / r_b holds for caps deeper than a hemisphere too
    s_b = r_b if H == 0.0 else 2.0 * math.atan(H / r_b) / kappa
    if not 0.0 < a < 0.5 * s_b:
        raise ValueError(f"disc_radius: {a!r} must lie in (0, s_b/2) = (0, {0.5 * s_b:.4g}) mm")
    s = np.concatenate([np.linspace(0.0, a, spec.n_disc + 1), a + _graded(s_b - a, spec, a)])
    zeta = np.linspace(-0.5 * t, 0.5 * t, spec.n_through + 1)
    param = MeshQuad2.from_mesh(MeshQuad.init_tensor(s, zeta))
    sp_, zp = param.doflocs
    sin_k, vers_k, cos_p = _curvature_terms(kappa, sp_)
    R = (1.0 + kappa * zp) * sin_k
    Z = H + zp * cos_p - vers_k
    R[np.abs(R) < 1e-14 * r_b] = 0.0
    mesh = MeshQuad2(np.vstack([R, Z]), param.t)
    return mesh, param, s_b
