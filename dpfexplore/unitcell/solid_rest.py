"""The axisymmetric solid's inverted rest: thickness and transverse shear where the shell has none.

The shell model (:mod:`dpfexplore._kernels.shell`) is shear-rigid and its thickness enters only
through ``C`` and ``D``; the scikit-fem solid of :mod:`.solid_check` resolves the section, so its
zero-force inverted state measures what the shell neglects in the state the lattice's reach and
its second minimum stand for, most in the thickest domes. :func:`solid_rest` finds it:

1. **Start.** The shell's mirror image carried through the thickness: a section point at
   mid-surface arclength ``s`` and distance ``ζ`` from the mid-surface moves by
   ``u = (−2 ζ sin(s/R), −2 z(s))``, ``z(s)`` the mid-surface height (the inverted mid-surface
   with every fibre kept normal to it and its orientation kept: no reflection of the material).
   Its free unknowns are the least-squares fit of ``u`` (the pin's and the apex's constraints
   are met exactly by the elimination of :class:`~.solid_check.SolidDome`), at ``δ = 2H``.
2. **Equilibrium at fixed travel** by Newton with a Levenberg shift and backtracking on the
   energy (the mirror is far from equilibrium: plain Newton diverges), then the path derivative
   ``dy/dδ`` from the converged tangent.
3. **The rest.** From ``δ = 2H`` in small steps to the shell's rest travel (tangent predictor),
   then the secant method on the apex force ``F(δ) = 0``. The apex load is ``"mean"`` (the
   column's mean travel held): at zero force it holds nothing, so the rest is the free
   solid's.

The rest is reported with its stability under displacement control (the reduced tangent);
with ``F`` rising through zero there, that is the free dome's stability.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from skfem import Basis, ElementQuad2, ElementVector, asm

from .solid_check import (
    _ONE_BLAS_THREAD,
    MeshSpec,
    SolidDome,
    _residual_form,
    _tangent_form,
)
from .solid_mesh import dome_mesh

__all__ = ["SolidRest", "solid_rest"]

#: Newton iterations of one equilibrium at fixed travel.
MAX_ITER = 80
#: Steps from the mirror's travel (2 H) to the shell's rest.
APPROACH = 8


@dataclass(frozen=True)
class SolidRest:
    """The solid's zero-force inverted state.

    Attributes
    ----------
    tip_dis : float, mm
        Apex travel (the column's mean) at zero apex force.
    energy : float, N·mm
    force : float, N
        The residual apex force there.
    stable : bool
        The reduced tangent at that travel is positive definite.
    converged : bool
    n_dofs : int
    elapsed : float, s
    """

    tip_dis: float
    energy: float
    force: float
    stable: bool
    converged: bool
    n_dofs: int
    elapsed: float


def _mirror(dome: SolidDome, H: float, t: float, r_b: float, spec: MeshSpec) -> np.ndarray:
    """The mirror image carried through the thickness, as nodal displacements (module doc)."""
    _, param, _ = dome_mesh(H, t, r_b, spec, dome.a)
    basis = Basis(param, ElementVector(ElementQuad2()))
    comp_r, comp_z = basis.split_indices()
    kappa = 2.0 * H / (r_b**2 + H**2)
    s, zeta = basis.doflocs
    z_mid = H - 2.0 * np.sin(0.5 * kappa * s) ** 2 / kappa
    u = np.zeros(basis.N)
    u[comp_r] = -2.0 * zeta[comp_r] * np.sin(kappa * s[comp_r])
    u[comp_z] = -2.0 * z_mid[comp_z]
    return u


def _equilibrium(dome: SolidDome, y: np.ndarray, delta: float):
    """Energy minimum at travel ``delta`` from ``y``: ``(y, converged, K, dy/dδ)``."""
    scale = dome.E * dome.t**2
    mu = 0.0
    K = None
    for _ in range(MAX_ITER):
        fields = dome._fields(dome.full(y, delta))
        r = dome.TT @ asm(_residual_form, dome.basis, P=fields["P"])
        K_full = asm(_tangent_form, dome.basis, D=fields["D"]).tocsr()
        K = dome.TT @ K_full @ dome.T
        if np.abs(r).max() < 1e-8 * scale:
            rate = splu(K.tocsc()).solve(-(dome.TT @ (K_full @ dome.e)))
            return y, True, K, rate
        energy = dome.energy(dome.full(y, delta))
        diag = float(np.abs(K.diagonal()).max())
        for _ in range(40):
            A = K + mu * sp.identity(K.shape[0], format="csr") if mu > 0 else K
            try:
                step = splu(A.tocsc()).solve(-r)
            except RuntimeError:  # singular: shift more
                mu = max(4.0 * mu, 1e-6 * diag)
                continue
            slope = float(r @ step)
            if not slope < 0.0:
                mu = max(4.0 * mu, 1e-6 * diag)
                continue
            length, accepted = 1.0, False
            for _ in range(12):
                trial = dome.energy(dome.full(y + length * step, delta))
                if np.isfinite(trial) and trial <= energy + 1e-4 * length * slope:
                    accepted = True
                    break
                length *= 0.5
            if accepted:
                y = y + length * step
                if length == 1.0:
                    mu *= 0.25
                break
            mu = max(4.0 * mu, 1e-6 * diag)
        else:
            break
    return y, False, K, np.zeros_like(y)


@_ONE_BLAS_THREAD
def solid_rest(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    guess: float,
    mesh: MeshSpec | None = None,
    material: str = "neo-hookean",
) -> SolidRest:
    """The solid's zero-force inverted state near the travel ``guess`` (mm; module docstring)."""
    started = time.perf_counter()
    spec = mesh or MeshSpec()
    dome = SolidDome(H, t, r_b, E, nu, spec, None, "mean", material)
    u = _mirror(dome, H, t, r_b, spec)
    y = np.linalg.lstsq(dome.T.toarray(), u - 2.0 * H * dome.e, rcond=None)[0]
    at = 2.0 * H
    y, converged, K, rate = _equilibrium(dome, y, at)

    def force(delta: float, start: np.ndarray, rate: np.ndarray, origin: float):
        state, ok, K, new_rate = _equilibrium(dome, start + (delta - origin) * rate, delta)
        return dome.force(dome.full(state, delta)), state, ok, K, new_rate

    f0 = dome.force(dome.full(y, at))
    for delta in np.linspace(at, guess, APPROACH + 1)[1:]:
        f0, y, converged, K, rate = force(float(delta), y, rate, at)
        at = float(delta)
    d0, d1 = at, at * 1.005
    f1, y1, converged, K, rate1 = force(d1, y, rate, d0)
    for _ in range(20):
        if abs(f1) < 1e-9 * E * t * t or f1 == f0:
            break
        d2 = d1 - f1 * (d1 - d0) / (f1 - f0)
        f2, y2, converged, K, rate2 = force(d2, y1, rate1, d1)
        d0, f0, d1, f1, y1, rate1 = d1, f1, d2, f2, y2, rate2
    return SolidRest(
        tip_dis=float(d1),
        energy=dome.energy(dome.full(y1, d1)),
        force=float(f1),
        stable=bool(dome.positive_definite(K)),
        converged=bool(converged),
        n_dofs=dome.n_dofs,
        elapsed=time.perf_counter() - started,
    )
