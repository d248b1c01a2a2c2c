"""An independent discretisation of one dome unit: a 2-D axisymmetric solid (issue 21 §3).

The cross-check of the shell model (:mod:`dpfexplore.unitcell.shell`): the same pinned spherical
cap, meshed through its thickness and solved as a geometrically nonlinear axisymmetric solid
with scikit-fem, under apex displacement control.

Formulation
-----------
* **Geometry.** The meridional section between the inner and outer surfaces, ``ζ ∈ [−t/2, t/2]``
  about the mid-surface of radius ``R = (r_b² + H²)/(2H)`` (MODEL.md §2), mapped exactly from a
  structured grid in (mid-surface arclength ``s``, ``ζ``) onto 9-node quadratic quadrilaterals
  (``MeshQuad2`` geometry, ``ElementQuad2`` displacements, 3×3 Gauss points). ``H = 0`` is the
  flat plate.
* **Kinematics** (total Lagrangian). Displacement ``u = (u_r, u_z)`` of the reference point
  ``(R, Z)``; ``F = [[1 + ∂u_r/∂R, ∂u_r/∂Z, 0], [∂u_z/∂R, 1 + ∂u_z/∂Z, 0], [0, 0, 1 + u_r/R]]``,
  ``E = (FᵀF − I)/2``.
* **Material.** St Venant–Kirchhoff, ``W = λ/2 (tr E)² + μ tr(E²)`` (the linear elastic law of
  the shell model, written in Green–Lagrange strain), energy ``Π = ∫ W 2π R dA``; residual
  ``∫ F S : δF 2π R dA`` and the consistent tangent as scikit-fem forms; Newton.
* **Pinned edge.** A pinned shell edge holds the mid-surface point of the edge fixed and lets the
  section rotate. In a solid, fixing that one point (a ring in 3-D) is a line constraint whose
  reaction is singular (its stiffness vanishes logarithmically under mesh refinement). Here the
  *mean* position of the edge face (the cut normal to the mid-surface at ``r_b``), weighted by its
  meridional length, is held: ``∫ u ds = 0`` over the face, two linear constraints, eliminated
  exactly. The face stays free to rotate and deform, its midpoint is the shell's pin on average,
  and the reaction is a distributed traction, so the energy converges under refinement.
* **Apex load.** A prescribed point displacement on a solid is singular (zero force in the
  limit). The apex travel ``δ`` is prescribed as ``u_z = −δ`` on the material *column* normal to
  the mid-surface within mid-surface arclength ``a`` of the axis (``apex="column"``, default
  ``a = t/2``), radial motion free; ``apex="mid"`` prescribes it on the mid-surface line of that
  disc only. The reaction ``F = dΠ/dδ``. The shell model's load is a point; the column is a small
  rigid boss; the sensitivity of the curve to ``a`` and to the choice is part of the report.
* **Path.** Displacement control in equal steps of ``δ`` (extrapolated predictor), each state
  checked for stability (the reduced tangent positive definite, by a banded Cholesky
  factorisation); the trace stops at the first fold in ``δ`` (where stability under displacement
  control is lost), located by step halving. This covers the stable first branch, which is what
  the cross-check compares.

Limits: axisymmetric (no polygonal modes, as the shell model); SVK and the shell's law agree to
first order in the strains, and differ at O(strain) relative in the energy density where strains
are large (under the apex column at deep travel).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import LinAlgError, cholesky_banded
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu
from skfem import (
    Basis,
    BilinearForm,
    ElementQuad2,
    ElementVector,
    FacetBasis,
    Functional,
    LinearForm,
    MeshQuad,
    MeshQuad2,
    asm,
)

__all__ = ["MeshSpec", "SolidCurve", "SolidDome", "dome_mesh", "solid_curve", "solid_stiffness"]

_TWO_PI = 2.0 * math.pi
#: 3×3 Gauss points per element: full integration of the 9-node quadrilateral (the mapping's
#: default, 5×5, costs 2.8 times as much and changes the stiffness by < 1e-4; see the tests).
_INTORDER = 5


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


def _gradient3(u, R: NDArray, identity: bool) -> NDArray:
    """Axisymmetric deformation gradient (or its variation) at quadrature points, (3, 3, ...)."""
    g = u.grad
    F = np.zeros((3, 3, *R.shape))
    F[0, 0], F[0, 1] = g[0, 0], g[0, 1]
    F[1, 0], F[1, 1] = g[1, 0], g[1, 1]
    F[2, 2] = u[0] / R
    if identity:
        F[0, 0] += 1.0
        F[1, 1] += 1.0
        F[2, 2] += 1.0
    return F


def _green(F: NDArray) -> NDArray:
    E = np.einsum("kI...,kJ...->IJ...", F, F)
    for i in range(3):
        E[i, i] -= 1.0
    return 0.5 * E


def _pk2(E: NDArray, lam: float, mu: float) -> NDArray:
    S = 2.0 * mu * E
    tr = E[0, 0] + E[1, 1] + E[2, 2]
    for i in range(3):
        S[i, i] += lam * tr
    return S


@Functional
def _energy_form(w):
    return w["W"] * _TWO_PI * w.x[0]


#: The nonzero components ``(i, J)`` of an axisymmetric deformation gradient.
_PAIRS = ((0, 0), (0, 1), (1, 0), (1, 1), (2, 2))


def _gradient5(u, R: NDArray) -> NDArray:
    """The five nonzero components of a displacement's ``δF`` (``_PAIRS`` order), (5, ...)."""
    g = u.grad
    return np.stack([g[0, 0], g[0, 1], g[1, 0], g[1, 1], u[0] / R])


def _svk(F: NDArray, lam: float, mu: float) -> dict:
    """St Venant–Kirchhoff: energy density, ``P = F S`` and ``∂P/∂F`` on the five components.

    ``∂P_iJ/∂F_kL = δ_ik S_JL + λ F_iJ F_kL + μ (F Fᵀ)_ik δ_JL + μ F_iL F_kJ``.
    """
    E = _green(F)
    tr = E[0, 0] + E[1, 1] + E[2, 2]
    W = 0.5 * lam * tr**2 + mu * np.einsum("IJ...,IJ...->...", E, E)
    S = _pk2(E, lam, mu)
    P = np.einsum("iK...,KJ...->iJ...", F, S)
    B = np.einsum("iK...,kK...->ik...", F, F)
    D = np.empty((5, 5, *F.shape[2:]))
    for a, (i, J) in enumerate(_PAIRS):
        for b, (k, L) in enumerate(_PAIRS):
            v = lam * F[i, J] * F[k, L] + mu * F[i, L] * F[k, J]
            if i == k:
                v = v + S[J, L]
            if J == L:
                v = v + mu * B[i, k]
            D[a, b] = v
    return {"W": W, "P": np.stack([P[i, J] for i, J in _PAIRS]), "D": D}


def _neo_hookean(F: NDArray, lam: float, mu: float) -> dict:
    """Compressible neo-Hookean, ``W = μ/2 (tr FᵀF − 3) − μ ln J + λ/2 (ln J)²``.

    ``P = μ (F − G) + λ ln J G`` and
    ``∂P_iJ/∂F_kL = μ δ_ik δ_JL + λ G_iJ G_kL + (μ − λ ln J) G_iL G_kJ`` with ``G = F⁻ᵀ``.
    ``J ≤ 0`` gives NaN, which the Newton solver reports as a failed step.
    """
    det2 = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    J = det2 * F[2, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        lnJ = np.where(J > 0.0, np.log(np.where(J > 0.0, J, 1.0)), np.nan)
        G = np.zeros_like(F)  # F⁻ᵀ of the block-diagonal F
        G[0, 0], G[0, 1] = F[1, 1] / det2, -F[1, 0] / det2
        G[1, 0], G[1, 1] = -F[0, 1] / det2, F[0, 0] / det2
        G[2, 2] = 1.0 / F[2, 2]
    I1 = np.einsum("iJ...,iJ...->...", F, F)
    W = 0.5 * mu * (I1 - 3.0) - mu * lnJ + 0.5 * lam * lnJ**2
    P = mu * (F - G) + lam * lnJ * G
    D = np.empty((5, 5, *F.shape[2:]))
    for a, (i, J_) in enumerate(_PAIRS):
        for b, (k, L) in enumerate(_PAIRS):
            v = lam * G[i, J_] * G[k, L] + (mu - lam * lnJ) * G[i, L] * G[k, J_]
            if i == k and J_ == L:
                v = v + mu
            D[a, b] = v
    return {"W": W, "P": np.stack([P[i, J_] for i, J_ in _PAIRS]), "D": D}


#: Materials by name: both are the linear elastic law (E, ν) at small strain.
MATERIALS = {"neo-hookean": _neo_hookean, "svk": _svk}


@LinearForm
def _residual_form(v, w):
    R = w.x[0]
    return np.einsum("a...,a...->...", w["P"], _gradient5(v, R)) * _TWO_PI * R


@BilinearForm
def _tangent_form(du, v, w):
    R = w.x[0]
    gu, gv = _gradient5(du, R), _gradient5(v, R)
    return np.einsum("a...,ab...,b...->...", gv, w["D"], gu) * _TWO_PI * R


@LinearForm
def _face_r(v, w):
    return v[0]


@LinearForm
def _face_z(v, w):
    return v[1]


@LinearForm
def _column_z(v, w):
    return v[1] * _TWO_PI * w.x[0]


class SolidDome:
    """The discretised dome: basis, dof sets, the pin's constraint and the forms' assembly.

    Parameters
    ----------
    H, t, r_b : float, mm
    E : float, MPa
    nu : float
    spec : MeshSpec
    disc_radius : float, mm
        Mid-surface arclength ``a`` of the loaded apex disc (default ``t/2``).
    apex : {"column", "mid"}
        Where ``u_z = −δ`` is prescribed: the whole column ``s ≤ a`` or its mid-surface line.
    """

    def __init__(
        self,
        H,
        t,
        r_b,
        E,
        nu,
        spec: MeshSpec,
        disc_radius=None,
        apex="mean",
        material="neo-hookean",
    ):
        for name, value in (("H", H), ("t", t), ("r_b", r_b), ("E", E)):
            if not (math.isfinite(value) and (value > 0 or (name == "H" and value == 0))):
                raise ValueError(f"{name}: {value!r} must be a positive finite number")
        if not -1.0 < nu < 0.5:
            raise ValueError(f"nu: {nu!r} must lie in (-1, 0.5)")
        if apex not in ("mean", "column", "mid"):
            raise ValueError(f"apex: {apex!r} must be 'mean', 'column' or 'mid'")
        if spec.n_through % 2:
            raise ValueError(f"n_through: {spec.n_through!r} must be even (mid-surface line)")
        self.H, self.t, self.r_b, self.E, self.nu = H, t, r_b, E, nu
        self.a = 0.5 * t if disc_radius is None else float(disc_radius)
        if material not in MATERIALS:
            raise ValueError(f"material: {material!r} must be one of {sorted(MATERIALS)}")
        self.spec, self.apex, self.material = spec, apex, material
        self.lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        self.mu = E / (2.0 * (1.0 + nu))
        self.mesh, param, s_b = dome_mesh(H, t, r_b, spec, self.a)
        element = ElementVector(ElementQuad2())
        self.basis = Basis(self.mesh, element, intorder=_INTORDER)
        # same topology, so dof numbering and facet indices agree with the physical basis
        pbasis = Basis(param, element)
        comp_r, comp_z = pbasis.split_indices()
        s_r, s_z = pbasis.doflocs[0, comp_r], pbasis.doflocs[0, comp_z]
        zeta_z = pbasis.doflocs[1, comp_z]
        tol = 1e-9 * (s_b + t)
        axis = comp_r[np.abs(s_r) < tol]
        on_disc = s_z <= self.a + tol
        if apex == "mid":
            on_disc &= np.abs(zeta_z) < tol
        n = self.basis.N
        # linear constraints c·u = g δ, each eliminated through a pivot dof
        constraints = []
        edge = param.facets_satisfying(lambda x: np.abs(x[0] - s_b) < tol)
        face = FacetBasis(self.mesh, element, facets=edge)
        c_r, c_z = asm(_face_r, face), asm(_face_z, face)
        self.face_length = float(c_r.sum())
        # the pin: ∫ u_r ds = ∫ u_z ds = 0 on the edge face
        constraints += [(c_r, 0.0), (c_z, 0.0)]
        self.e = np.zeros(n)  # ∂u/∂δ at fixed free unknowns
        if apex == "mean":
            # the column's volume-mean u_z is −δ: its reaction is a uniform body force there
            column = param.elements_satisfying(lambda x: x[0] <= self.a + tol)
            cbasis = Basis(self.mesh, element, elements=column, intorder=_INTORDER)
            c_col = asm(_column_z, cbasis)
            constraints.append((c_col, -float(c_col.sum())))
            fixed = axis
        else:
            self.e[comp_z[on_disc]] = -1.0
            fixed = np.union1d(axis, comp_z[on_disc])
        movable = np.ones(n)
        movable[fixed] = 0.0
        pivots = [int(np.argmax(np.abs(c) * movable)) for c, _ in constraints]
        self.free = np.setdiff1d(np.arange(n), np.union1d(fixed, pivots))
        col = np.full(n, -1)
        col[self.free] = np.arange(self.free.size)
        rows, cols, vals = list(self.free), list(range(self.free.size)), [1.0] * self.free.size
        for (c, g), p in zip(constraints, pivots, strict=True):
            support = np.flatnonzero((np.abs(c) > 0) & (col >= 0))
            rows += [p] * support.size
            cols += list(col[support])
            vals += list(-c[support] / c[p])
            self.e[p] = g / c[p]
        self.T = sp.csr_matrix((vals, (rows, cols)), shape=(n, self.free.size))
        self.TT = self.T.T.tocsr()
        self.n_dofs = int(self.free.size)
        self._perm: NDArray | None = None

    def full(self, y: NDArray, delta: float) -> NDArray:
        """All nodal displacements (mm) from the free unknowns ``y`` and the apex travel."""
        return self.T @ y + delta * self.e

    def _fields(self, u: NDArray) -> dict:
        w = self.basis.interpolate(u)
        F = _gradient3(w, self.basis.global_coordinates()[0], True)
        return MATERIALS[self.material](F, self.lam, self.mu)

    def energy(self, u: NDArray) -> float:
        """Strain energy Π (N·mm) of the displacement ``u``."""
        return float(asm(_energy_form, self.basis, W=self._fields(u)["W"]))

    def residual(self, u: NDArray) -> NDArray:
        """``∂Π/∂u`` (N) at every dof."""
        return asm(_residual_form, self.basis, P=self._fields(u)["P"])

    def tangent(self, u: NDArray) -> sp.csr_matrix:
        """``∂²Π/∂u²`` (N/mm), the consistent tangent."""
        return asm(_tangent_form, self.basis, D=self._fields(u)["D"]).tocsr()

    def force(self, u: NDArray) -> float:
        """Apex reaction ``F = dΠ/dδ = ∂Π/∂u · ∂u/∂δ`` (N) at an equilibrium ``u``."""
        return float(self.residual(u) @ self.e)

    def positive_definite(self, K: sp.csr_matrix) -> bool:
        """Whether the reduced tangent is positive definite (banded Cholesky after RCM)."""
        if self._perm is None:
            self._perm = reverse_cuthill_mckee(K, symmetric_mode=True)
        Kp = K[self._perm][:, self._perm].tocoo()
        upper = Kp.row <= Kp.col
        i, j, v = Kp.row[upper], Kp.col[upper], Kp.data[upper]
        bw = int((j - i).max())
        ab = np.zeros((bw + 1, K.shape[0]))
        ab[bw + i - j, j] = v
        try:
            cholesky_banded(ab, lower=False, check_finite=False)
        except LinAlgError:
            return False
        return True

    def solve(self, y: NDArray, delta: float, *, rtol: float = 1e-9, max_iter: int = 12):
        """Newton on the free unknowns at apex travel ``delta``.

        Returns
        -------
        y : ndarray (n_dofs,), mm
            The last iterate.
        converged : bool
        K : sparse matrix (n_dofs, n_dofs), N/mm
            The reduced tangent at the last iterate.
        rate : ndarray (n_dofs,), mm/mm
            ``dy/dδ`` along the equilibrium path there (the tangent predictor of the next step).
        """
        scale = self.E * self.t**2  # N: force scale of the residual
        e = self.e
        y = y.copy()
        converged = False
        for _ in range(max_iter):
            u = self.full(y, delta)
            fields = self._fields(u)
            r = self.TT @ asm(_residual_form, self.basis, P=fields["P"])
            K_full = asm(_tangent_form, self.basis, D=fields["D"]).tocsr()
            K = self.TT @ K_full @ self.T
            if not np.all(np.isfinite(r)):
                break
            lu = splu(K.tocsc())
            dy = lu.solve(-r)
            y += dy
            if np.abs(dy).max() < rtol * (self.H + self.t) and np.abs(r).max() < 1e-6 * scale:
                converged = True
                break
        rate = lu.solve(-(self.TT @ (K_full @ e))) if converged else np.zeros_like(y)
        return y, converged, K, rate


@dataclass(frozen=True, eq=False)
class SolidCurve:
    """The solid's stable first branch under apex displacement control.

    Attributes
    ----------
    displacement : ndarray (n,), mm
        Apex travel, from 0.
    force : ndarray (n,), N
        Apex reaction ``dΠ/dδ``.
    energy : ndarray (n,), N·mm
        Strain energy.
    fold : float or None, mm
        Travel of the last stable state before the first fold in ``δ`` (within the smallest
        step ``travel / n_steps / 2**halvings``); None unless ``status`` is ``fold``.
    status : str
        ``reached``; ``fold`` (stopped at the first fold: the next state, at the smallest step,
        is unstable or on another branch); ``failed`` (Newton did not converge at the smallest
        step: for SVK, the material's collapse under large compression).
    n_dofs : int
        Free unknowns.
    elapsed : float, s
        Wall time of the trace.
    """

    H: float
    t: float
    r_b: float
    E: float
    nu: float
    spec: MeshSpec
    disc_radius: float
    apex: str
    displacement: NDArray
    force: NDArray
    energy: NDArray
    fold: float | None
    status: str
    n_dofs: int
    elapsed: float


def solid_curve(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    travel: float | None = None,
    n_steps: int = 40,
    mesh: MeshSpec | None = None,
    disc_radius: float | None = None,
    apex: str = "column",
    material: str = "neo-hookean",
    halvings: int = 5,
) -> SolidCurve:
    """Trace the solid dome's stable first branch under apex displacement control.

    Parameters
    ----------
    H, t, r_b : float, mm
        Mid-surface height, thickness and base radius.
    E : float, MPa
    nu : float
    travel : float, mm, optional
        Largest apex travel (default ``2 H``, past the first fold of every dome of the box).
    n_steps : int
        Equal travel steps up to ``travel``.
    mesh : MeshSpec, optional
        Default ``MeshSpec()``.
    disc_radius : float, mm, optional
        Mid-surface arclength of the loaded apex disc (default ``t/2``).
    apex : {"column", "mid"}
        See :class:`SolidDome`.
    halvings : int
        Step halvings used to locate the fold.

    Returns
    -------
    SolidCurve
    """
    start = time.perf_counter()
    dome = SolidDome(H, t, r_b, E, nu, mesh or MeshSpec(), disc_radius, apex, material)
    travel = 2.0 * H if travel is None else float(travel)
    step = travel / n_steps
    y, _, _, rate = dome.solve(np.zeros(dome.n_dofs), 0.0)
    deltas, forces, energies = [0.0], [0.0], [0.0]
    status, fold, level = "reached", None, 0
    while deltas[-1] < travel * (1.0 - 1e-12):
        h = min(step / 2**level, travel - deltas[-1])
        d = deltas[-1] + h
        # tangent predictor: the converged state moved along its own path derivative
        y_new, ok, K_new, rate_new = dome.solve(y + h * rate, d)
        reason = "fold" if ok else "failed"
        ok = ok and dome.positive_definite(K_new)
        if ok:
            u = dome.full(y_new, d)
            f = dome.force(u)
            # a converged, stable state far off the predicted force is another branch
            if len(forces) > 1:
                slope = (forces[-1] - forces[-2]) / (deltas[-1] - deltas[-2])
                ok = abs(f - (forces[-1] + slope * h)) <= 0.1 * max(np.abs(forces).max(), 1e-12)
        if not ok:
            if level < halvings:
                level += 1
                continue
            # a stable state whose neighbour is unstable or elsewhere is a fold; a Newton
            # failure while stable is reported as such
            status, fold = reason, deltas[-1] if reason == "fold" else None
            break
        y, rate = y_new, rate_new
        deltas.append(d)
        forces.append(f)
        energies.append(dome.energy(u))
    return SolidCurve(
        H=H,
        t=t,
        r_b=r_b,
        E=E,
        nu=nu,
        spec=dome.spec,
        disc_radius=dome.a,
        apex=apex,
        displacement=np.array(deltas),
        force=np.array(forces),
        energy=np.array(energies),
        fold=fold,
        status=status,
        n_dofs=dome.n_dofs,
        elapsed=time.perf_counter() - start,
    )


def solid_stiffness(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    mesh: MeshSpec | None = None,
    disc_radius: float | None = None,
    apex: str = "column",
    material: str = "neo-hookean",
) -> float:
    """Small-deflection apex stiffness ``dF/dδ`` (N/mm) of the undeformed solid dome.

    One linear solve with the tangent at the reference state (``H = 0``: the pinned plate).
    """
    dome = SolidDome(H, t, r_b, E, nu, mesh or MeshSpec(), disc_radius, apex, material)
    u0 = np.zeros(dome.basis.N)
    K = dome.tangent(u0)
    # unit apex travel: u = T y + e; the reduced equations Tᵀ K T y = −Tᵀ K e
    e = dome.e
    Kr = dome.TT @ K @ dome.T
    y = splu(Kr.tocsc()).solve(-(dome.TT @ (K @ e)))
    u = dome.T @ y + e
    return float((K @ u) @ e)
