"""Small banded linear algebra for the Newton solver (matrices of order 4N - 2 <= 46).

LAPACK's call overhead dominates at these sizes, so the banded Cholesky factorisation and the
triangular solves are written out; the rare eigen-decompositions go to ``np.linalg`` (LAPACK
through Numba).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel


@kernel(inline="always")
def bandwidth(n):
    """Lower bandwidth of the lattice Hessian of order ``n`` (see :mod:`.layout`).

    Free nodes come in per-post blocks ``(D_k, L_k)`` of four coordinates (two for ``D_1``), and
    every spring joins nodes of the same or adjacent posts, so the Hessian is block-tridiagonal:
    no entry lies further than 7 below the diagonal.
    """
    return min(n - 1, 7)


@kernel(inline="always")
def cholesky(a, shift, low, n):
    """Lower Cholesky factor of ``a + shift·I`` into ``low`` (leading ``n x n`` block).

    Only the band of :func:`bandwidth` is touched (a Cholesky factor keeps the band of its
    matrix), which halves the work at N = 5 and cuts it 14-fold at N = 12.

    Returns
    -------
    bool
        False if the matrix is not (numerically) positive definite; ``low`` is then garbage.
    """
    bw = bandwidth(n)
    for j in range(n):
        k0 = max(0, j - bw)
        s = a[j, j] + shift
        for k in range(k0, j):
            s -= low[j, k] * low[j, k]
        if not s > 0.0:  # also catches NaN
            return False
        diag = math.sqrt(s)
        low[j, j] = diag
        inv = 1.0 / diag
        for i in range(j + 1, min(n, j + bw + 1)):
            s = a[i, j]
            for k in range(max(0, i - bw), j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s * inv
    return True


@kernel(inline="always")
def cholesky_solve(low, b, out, n):
    """Solve ``L Lᵀ out = b`` given the banded lower factor ``low`` from :func:`cholesky`."""
    bw = bandwidth(n)
    for i in range(n):
        s = b[i]
        for k in range(max(0, i - bw), i):
            s -= low[i, k] * out[k]
        out[i] = s / low[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, min(n, i + bw + 1)):
            s -= low[k, i] * out[k]
        out[i] = s / low[i, i]


@kernel(inline="always")
def max_abs(v, n):
    """Largest absolute entry of ``v[:n]`` (NaN-propagating)."""
    m = 0.0
    for i in range(n):
        a = abs(v[i])
        if a > m or a != a:
            m = a
    return m


@kernel
def smallest_eigenvalue(a, n):
    """Smallest eigenvalue of the symmetric ``a[:n, :n]`` (LAPACK ``eigvalsh``)."""
    return np.linalg.eigvalsh(np.ascontiguousarray(a[:n, :n]))[0]


@kernel
def smallest_eigenvalue_factored(a, low, n, rtol, max_iter, v, w):
    """Smallest eigenvalue of the positive definite ``a`` by inverse iteration.

    ``low`` is the Cholesky factor of ``a``, so each iteration costs two triangular solves. The
    Rayleigh quotient is accepted once the residual ``r = |a v - λ v|`` is below ``rtol·λ``: for
    a symmetric matrix an eigenvalue then lies within ``r`` of it, and within ``r²/gap`` (Kato-
    Temple) once the gap to the next eigenvalue is resolved, so ``rtol = 1e-7`` gives the value
    to about 1e-14 relative. Inverse iteration from a vector with weight on every mode converges
    to the smallest eigenvalue. When the two smallest
    eigenvalues are too close for that within ``max_iter`` iterations, LAPACK decides.
    """
    for i in range(n):
        v[i] = 1.0 + 0.01 * i  # weight on every mode; not an eigenvector of the lattice
    lam = 0.0
    for _ in range(max_iter):
        norm = 0.0
        for i in range(n):
            norm += v[i] * v[i]
        norm = math.sqrt(norm)
        for i in range(n):
            v[i] /= norm
        cholesky_solve(low, v, w, n)
        # Rayleigh quotient of a at v: vᵀ a v with v normalised; a v from the matrix directly.
        lam = 0.0
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += a[i, j] * v[j]
            lam += v[i] * s
        residual = 0.0
        for i in range(n):
            s = -lam * v[i]
            for j in range(n):
                s += a[i, j] * v[j]
            residual += s * s
        if math.sqrt(residual) <= rtol * abs(lam):
            return lam
        for i in range(n):
            v[i] = w[i]
    return smallest_eigenvalue(a, n)
