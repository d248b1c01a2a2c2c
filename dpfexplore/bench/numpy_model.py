"""The lattice energy and gradient in vectorised NumPy: the SciPy baseline, and a test oracle.

This is deliberately a second, independent implementation of MODEL.md §5, written the way a
careful NumPy user would (whole spring arrays at once, ``np.add.at`` scatter), so that the
benchmark compares our kernels against a fair baseline and the tests can check the kernels
against code that shares none of their structure. Nothing in the package's hot paths calls it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels import layout as lay


@dataclass(frozen=True)
class NumpyLattice:
    """Spring tables of one design for the vectorised energy."""

    n_units: int
    h: float
    clamped: NDArray  # (3, 2) positions of D0, L0, L1
    lin_a: NDArray
    lin_b: NDArray
    lin_rest: NDArray
    lin_k: NDArray
    dome_a: NDArray
    dome_b: NDArray
    dome_rest: NDArray
    kb: NDArray
    alpha: NDArray
    d: NDArray
    tor_a: NDArray
    tor_c: NDArray
    tor_b: NDArray
    kt: NDArray

    @classmethod
    def from_params(cls, unit_params: NDArray, h: float) -> NumpyLattice:
        """Build the tables from a kernel parameter table (``lattice_params(design)``)."""
        n = unit_params.shape[0]
        k = np.arange(1, n + 1)
        col = unit_params.T
        # posts D_k-L_k and layer L_{k-1}-L_k (the first layer segment is clamped at both ends)
        lin_a = np.concatenate([2 * k, (2 * k + 1)[1:]])
        lin_b = np.concatenate([2 * k + 1, (2 * k - 1)[1:]])
        lin_rest = np.concatenate([np.full(n, h), col[lay.COL_P][1:]])
        lin_k = np.concatenate([col[lay.COL_KPOST], col[lay.COL_KLIM][1:]])
        kk = k[:-1]
        tor_a = np.concatenate([2 * k - 1, 2 * kk])
        tor_c = np.concatenate([2 * k + 1, 2 * kk + 1])
        tor_b = np.concatenate([2 * k, 2 * kk + 3])
        kt = np.concatenate([col[lay.COL_KT], col[lay.COL_KT][:-1]])
        clamped = np.array([[0.0, 0.0], [0.0, h], [col[lay.COL_P][0], h]])
        return cls(
            n,
            h,
            clamped,
            lin_a,
            lin_b,
            lin_rest,
            lin_k,
            2 * k,
            2 * k - 2,
            col[lay.COL_P].copy(),
            col[lay.COL_KB].copy(),
            col[lay.COL_ALPHA].copy(),
            col[lay.COL_D].copy(),
            tor_a,
            tor_c,
            tor_b,
            kt,
        )

    def nodes(self, x: NDArray) -> NDArray:
        """All node positions ``(2N + 2, 2)`` from free coordinates."""
        pos = np.empty((2 * self.n_units + 2, 2))
        pos[[0, 1, 3]] = self.clamped
        free = np.array([2, *range(4, 2 * self.n_units + 2)])
        pos[free] = x.reshape(-1, 2)
        return pos

    def energy_and_gradient(self, x: NDArray) -> tuple[float, NDArray]:
        """Energy (N·mm) and gradient (N) in the free coordinates."""
        pos = self.nodes(x)
        g = np.zeros_like(pos)
        energy = 0.0
        # linear springs
        v = pos[self.lin_a] - pos[self.lin_b]
        ell = np.linalg.norm(v, axis=1)
        stretch = ell - self.lin_rest
        energy += 0.5 * np.sum(self.lin_k * stretch**2)
        f = (self.lin_k * stretch / ell)[:, None] * v
        np.add.at(g, self.lin_a, f)
        np.add.at(g, self.lin_b, -f)
        # domes
        v = pos[self.dome_a] - pos[self.dome_b]
        ell = np.linalg.norm(v, axis=1)
        xb = ell - self.dome_rest
        u = xb / self.d
        c = 1.0 - self.alpha
        energy += np.sum(0.5 * self.kb * xb**2 * (1.0 + c * (u * u - 2.0 * u)))
        f = (self.kb * xb * (1.0 + c * (2.0 * u * u - 3.0 * u)) / ell)[:, None] * v
        np.add.at(g, self.dome_a, f)
        np.add.at(g, self.dome_b, -f)
        # torsion: δ = atan2(-va·vb, va×vb), ∇ via polar angles of the arms
        va = pos[self.tor_a] - pos[self.tor_c]
        vb = pos[self.tor_b] - pos[self.tor_c]
        cross = va[:, 0] * vb[:, 1] - va[:, 1] * vb[:, 0]
        dot = np.sum(va * vb, axis=1)
        delta = np.arctan2(-dot, cross)
        energy += 0.5 * np.sum(self.kt * delta**2)
        ga = np.column_stack([-va[:, 1], va[:, 0]]) / np.sum(va * va, axis=1)[:, None]
        gb = np.column_stack([-vb[:, 1], vb[:, 0]]) / np.sum(vb * vb, axis=1)[:, None]
        s = (self.kt * delta)[:, None]
        np.add.at(g, self.tor_a, -s * ga)
        np.add.at(g, self.tor_c, s * (ga - gb))
        np.add.at(g, self.tor_b, s * gb)
        free = np.array([2, *range(4, 2 * self.n_units + 2)])
        return float(energy), g[free].ravel()

    def geometric_guess(self, state: int, c: float = 1.0) -> NDArray:
        """The paper's geometric guess (MODEL.md §6), as in :mod:`dpfexplore._kernels.statics`."""
        n = self.n_units
        pos = np.empty((2 * n + 2, 2))
        phi, lx, ly = 0.0, 0.0, self.h
        for k in range(1, n + 1):
            lx += self.dome_rest[k - 1] * np.cos(phi)
            ly += self.dome_rest[k - 1] * np.sin(phi)
            if state >> (n - k) & 1:
                phi += np.arctan(c * self.d[k - 1] / self.h)
            pos[2 * k] = (lx + self.h * np.sin(phi), ly - self.h * np.cos(phi))
            pos[2 * k + 1] = (lx, ly)
        free = np.array([2, *range(4, 2 * n + 2)])
        return pos[free].ravel()
