"""Small profile (skyline) linear algebra for the Newton solver (matrices of order 4N - 2 <= 46).

LAPACK's call overhead dominates at these sizes, so the profile Cholesky factorisation and the
triangular solves are written out; the rare eigen-decompositions go to ``np.linalg`` (LAPACK
through Numba).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel


@kernel(inline="always")
def profile_start(i):
    """First column of row ``i`` of the lattice Hessian that may be non-zero (see :mod:`.layout`).

    Free coordinates come in per-post blocks: ``D_1`` (coordinates 0-1), then ``(D_k, L_k)`` for
    ``k >= 2`` (four coordinates from ``2 + 4(k - 2)``). Every spring joins nodes of the same or
    adjacent posts, so row ``i`` is zero left of the block before its own: a profile (skyline)
    of 4-7 entries left of the diagonal. A Cholesky factor keeps the profile of its matrix.
    """
    if i < 6:  # D_1 and post 2: the profile starts at column 0
        return 0
    return 4 * ((i - 2) // 4) - 2


@kernel(inline="always")
def profile_end(j, n):
    """Last row whose profile (:func:`profile_start`) reaches column ``j``: the next post's end."""
    if j < 2:
        return min(n - 1, 5)
    return min(n - 1, 4 * ((j - 2) // 4) + 9)


@kernel(inline="always")
def cholesky(a, shift, low, n):
    """Lower Cholesky factor of ``a + shift·I`` into ``low`` (leading ``n x n`` block).

    Only the profile of :func:`profile_start` is read or written; entries of ``low`` outside
    it are left as they were and never read by :func:`cholesky_solve`. At N = 5 this does a
    third of the dense work, at N = 12 a twentieth.

    Returns
    -------
    bool
        False if the matrix is not (numerically) positive definite; ``low`` is then garbage.
    """
    for j in range(n):
        s = a[j, j] + shift
        for k in range(profile_start(j), j):
            s -= low[j, k] * low[j, k]
        if not s > 0.0:  # also catches NaN
            return False
        diag = math.sqrt(s)
        low[j, j] = diag
        inv = 1.0 / diag
        for i in range(j + 1, profile_end(j, n) + 1):
            s = a[i, j]
            # row i's profile starts at or after row j's (j < i), so this covers both
            for k in range(profile_start(i), j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s * inv
    return True


@kernel(inline="always")
def cholesky_solve(low, b, out, n):
    """Solve ``L Lᵀ out = b`` given the profile lower factor ``low`` from :func:`cholesky`."""
    for i in range(n):
        s = b[i]
        for k in range(profile_start(i), i):
            s -= low[i, k] * out[k]
        out[i] = s / low[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, profile_end(i, n) + 1):
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
