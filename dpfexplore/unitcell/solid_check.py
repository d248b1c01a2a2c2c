"""An independent discretisation of one dome unit: a 2-D axisymmetric solid.

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
* **Material.** Two laws with the linear elastic ``E``, ``ν`` at small strain: St Venant–Kirchhoff
  ``W = λ/2 (tr E)² + μ tr(E²)``, and (the default) the compressible neo-Hookean
  ``W = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²``. SVK's stress in compression peaks at a stretch
  of ``1/√3`` and its energy vanishes again for reflections: under the apex of the paper's
  thick domes the strains pass 40 % and SVK lets the material at the column's corner collapse
  (H = 3, t = 1: the energy drops at 0.35 H of travel, Newton fails at 0.94 H), which
  neo-Hookean does not. The energy
  ``Π = ∫ W 2π R dA``, the residual ``∫ P : δF 2π R dA`` and the consistent tangent
  ``∫ δF : ∂P/∂F : ΔF 2π R dA`` are scikit-fem forms; Newton on the free unknowns.
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
  ``a = t/2``), radial motion free; ``apex="mean"`` prescribes instead the column's
  volume-mean ``u_z`` (its reaction is a uniform body force in the column, no rigid corners).
  The reaction is ``F = dΠ/dδ``. The shell model's load is a point: a solid has no such limit
  (its transverse shear makes the compliance grow like ``−ln a``). The rigid column (stiffer
  than a point load on a shear-rigid shell) and the spread load (softer) bracket it; the
  curve's sensitivity to ``a`` and to the choice is part of the report.
* **Path.** Displacement control in equal steps of ``δ`` (tangent predictor), each state
  checked for stability (the reduced tangent positive definite, by a banded Cholesky
  factorisation); the trace stops at the first fold in ``δ`` (where stability under displacement
  control is lost), located by step halving. This covers the stable first branch, which is what
  the cross-check compares.

Limits: axisymmetric (no polygonal modes, as the shell model); the laws agree with the
shell's to first order in the strains and differ where the strains are large (next to the
loaded column, where they reach tens of percent in thick domes).
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
    asm,
)
from threadpoolctl import threadpool_limits

from .solid_materials import MATERIALS, _gradient3
from .solid_mesh import MeshSpec, dome_mesh

__all__ = ["MeshSpec", "SolidCurve", "SolidDome", "dome_mesh", "solid_curve", "solid_stiffness"]

_TWO_PI = 2.0 * math.pi
#: 3×3 Gauss points per element: full integration of the 9-node quadrilateral (the mapping's
#: default, 5×5, costs 2.8 times as much and changed the apex stiffness of the t = 0.1 plate and
#: of the H = 3, t = 1 dome by less than 1e-8 relative).
_INTORDER = 5


@Functional
def _energy_form(w):
    return w["W"] * _TWO_PI * w.x[0]


def _gradient5(u, R: NDArray) -> NDArray:
    """The five nonzero components of a displacement's ``δF`` (solid_materials._PAIRS order)."""
    g = u.grad
    return np.stack([g[0, 0], g[0, 1], g[1, 0], g[1, 1], u[0] / R])


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
    apex : {"column", "mean"}
        ``column``: ``u_z = −δ`` at every node of the column ``s ≤ a`` (a rigid boss through
        the thickness); ``mean``: the column's volume-mean ``u_z`` is ``−δ``.
    material : {"neo-hookean", "svk"}
    """

    def __init__(
        self,
        H: float,
        t: float,
        r_b: float,
        E: float,
        nu: float,
        spec: MeshSpec,
        disc_radius: float | None = None,
        apex: str = "column",
        material: str = "neo-hookean",
    ):
        for name, value in (("H", H), ("t", t), ("r_b", r_b), ("E", E)):
            if not (math.isfinite(value) and (value > 0 or (name == "H" and value == 0))):
                raise ValueError(f"{name}: {value!r} must be a positive finite number")
        if not -1.0 < nu < 0.5:
            raise ValueError(f"nu: {nu!r} must lie in (-1, 0.5)")
        if apex not in ("mean", "column"):
            raise ValueError(f"apex: {apex!r} must be 'column' or 'mean'")
        if spec.n_through % 2:
            raise ValueError(f"n_through: {spec.n_through!r} must be even (mid-surface line)")
        self.H, self.t, self.r_b, self.E, self.nu = H, t, r_b, E, nu
        self.a = 0.5 * t if disc_radius is None else float(disc_radius)
        if material not in MATERIALS:
            raise ValueError(
                f"material: {material!r} must be one of {', '.join(sorted(MATERIALS))}"
            )
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
        tol = 1e-9 * (s_b + t)
        axis = comp_r[np.abs(s_r) < tol]
        on_disc = s_z <= self.a + tol
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
    cpu : float, s
        CPU time of the process during the trace (robust to other load on the machine).
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
    cpu: float


#: A trace that stops with the lowest eigenvalue of the reduced tangent below this fraction of
#: the undeformed dome's is at a fold (see :func:`solid_curve`).
FOLD_RATIO = 0.2


def _lowest_eigenvalue(K: sp.csr_matrix) -> float:
    """Lowest eigenvalue (N/mm) of a symmetric sparse matrix, by shift-invert about zero."""
    from scipy.sparse.linalg import eigsh

    return float(eigsh(K.tocsc(), k=1, sigma=0.0, which="LM", return_eigenvectors=False)[0])


#: BLAS on one thread: the model's dense work (banded Cholesky of a few hundred unknowns) is far
#: too small to share, and idle BLAS threads slow it 4-15 times on a loaded machine.
_ONE_BLAS_THREAD = threadpool_limits.wrap(limits=1, user_api="blas")


@_ONE_BLAS_THREAD
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
    apex : {"column", "mean"}
        See :class:`SolidDome`.
    material : {"neo-hookean", "svk"}
        See :class:`SolidDome`.
    halvings : int
        Step halvings used to locate the fold.

    Returns
    -------
    SolidCurve
    """
    start, cpu_start = time.perf_counter(), time.process_time()
    dome = SolidDome(H, t, r_b, E, nu, mesh or MeshSpec(), disc_radius, apex, material)
    travel = 2.0 * H if travel is None else float(travel)
    step = travel / n_steps
    y, _, K, rate = dome.solve(np.zeros(dome.n_dofs), 0.0)
    lowest0 = _lowest_eigenvalue(K)
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
                guess = forces[-1] + slope * h
                ok = abs(f - guess) <= 0.2 * max(abs(guess), np.abs(forces).max())
        if not ok:
            if level < halvings:
                level += 1
                continue
            # at the smallest step: a fold if the last state is close to losing stability (its
            # lowest tangent eigenvalue fallen well below the undeformed dome's; near a fold it
            # vanishes like the square root of the distance), else a failure of the solver
            ratio = _lowest_eigenvalue(K) / lowest0
            status = "fold" if reason == "fold" or ratio < FOLD_RATIO else "failed"
            fold = deltas[-1] if status == "fold" else None
            break
        y, rate, K = y_new, rate_new, K_new
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
        cpu=time.process_time() - cpu_start,
    )


@_ONE_BLAS_THREAD
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
