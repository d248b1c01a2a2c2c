"""Axisymmetric kinematics and the two hyperelastic laws of :mod:`.solid_check`.

Arrays at quadrature points, shaped ``(3, 3, n_elements, n_points)`` for tensors. A law returns
its energy density ``W`` (N·mm/mm³ = MPa), the first Piola stress ``P`` and its derivative
``∂P/∂F`` on the five nonzero components of an axisymmetric ``F`` (``_PAIRS``), so that the
scikit-fem forms evaluated per pair of basis functions are a 5-vector and 5×5 contraction.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["MATERIALS"]


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


#: The nonzero components ``(i, J)`` of an axisymmetric deformation gradient.
_PAIRS = ((0, 0), (0, 1), (1, 0), (1, 1), (2, 2))


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
