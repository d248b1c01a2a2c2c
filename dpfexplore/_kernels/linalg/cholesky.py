"""Small block-tridiagonal linear algebra for the Newton solver (matrices of order 4N - 2 <= 46).

LAPACK's call overhead dominates at these sizes, so the Cholesky factorisation and the
triangular solves are written out for the lattice Hessian's block structure (one block per
post, :func:`block_start`); the rare eigen-decompositions go to ``np.linalg`` (LAPACK through
Numba). Block by block, the factor's zero blocks are never touched (docs/decisions.md, "Newton
steps", has the measurements against a profile-Cholesky variant).

:func:`cholesky` and :func:`cholesky_solve` are compiled once as functions of their own (their
block helpers are inlined into them, with the constant block sizes the loops unroll on) rather
than inlined into each of their six callers: Numba re-optimises every callee a function links,
so each inlined copy cost compile time in every kernel above it, and the call costs nothing
measurable against a factorisation.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel


@kernel(inline="always")
def block_start(b):
    """First free coordinate of post block ``b`` of the lattice Hessian (see :mod:`.layout`).

    Free coordinates come in per-post blocks: ``D_1`` (block 0, coordinates 0-1), then
    ``(D_k, L_k)`` for ``k >= 2`` (block ``k - 1``, four coordinates from ``2 + 4(k - 2)``).
    Every spring joins nodes of the same or adjacent posts, so the Hessian is block tridiagonal,
    and so is its Cholesky factor (block lower bidiagonal).
    """
    return 0 if b == 0 else 4 * b - 2


@kernel(inline="always")
def block_size(b):
    """Number of free coordinates of post block ``b``: 2 for ``D_1``, 4 after."""
    return 2 if b == 0 else 4


@kernel(inline="always")
def n_blocks(n):
    """Number of post blocks of ``n = 4N - 2`` free coordinates (``N``)."""
    return (n + 2) // 4


@kernel(inline="always")
def _factor_diagonal_block(a, low, shift, r0, m, p0, pm):
    """Factor the diagonal block at ``r0`` (size ``m``) after the block at ``p0`` (size ``pm``).

    ``S = A_bb + shift I - L_{b,b-1} L_{b,b-1}ᵀ = L_bb L_bbᵀ``. The two partial sums are kept
    apart so that their dependency chains overlap. Returns False if ``S`` is not positive
    definite (or not finite).
    """
    for i in range(m):
        ri = r0 + i
        for j in range(i + 1):
            rj = r0 + j
            previous = 0.0
            for k in range(pm):
                previous += low[ri, p0 + k] * low[rj, p0 + k]
            own = 0.0
            for k in range(j):
                own += low[ri, r0 + k] * low[rj, r0 + k]
            s = a[ri, rj] - previous - own
            if i == j:
                s += shift
                if not s > 0.0:  # also catches NaN
                    return False
                low[ri, ri] = 1.0 / math.sqrt(s)
            else:
                low[ri, rj] = s * low[rj, rj]
    return True


@kernel(inline="always")
def _factor_coupling_block(a, low, r0, m):
    """``L_{b+1,b} = A_{b+1,b} L_bb⁻ᵀ`` for the block at ``r0`` (size ``m``); the next has 4."""
    q0 = r0 + m
    for j in range(m):
        rj = r0 + j
        inv = low[rj, rj]
        for i in range(4):
            qi = q0 + i
            s = a[qi, rj]
            for k in range(j):
                s -= low[qi, r0 + k] * low[rj, r0 + k]
            low[qi, rj] = s * inv


@kernel
def cholesky(a, shift, low, n):
    """Block-tridiagonal Cholesky factor of ``a + shift·I`` into ``low`` (leading ``n x n``).

    Only the blocks of :func:`block_start` on and below the diagonal are read or written; the
    other entries of ``low`` are left as they were and never read by :func:`cholesky_solve`.
    The diagonal of ``low`` holds the *reciprocals* of the factor's diagonal: at these sizes
    the chain of square roots and divisions from one column to the next is what takes the
    time, and a multiplication is several times shorter than a division. Blocks are handled
    with constant sizes (2 then 4) so that the compiler unrolls their loops.

    Returns
    -------
    bool
        False if the matrix is not (numerically) positive definite; ``low`` is then garbage.
    """
    nb = n_blocks(n)
    if not _factor_diagonal_block(a, low, shift, 0, 2, 0, 0):
        return False
    if nb == 1:
        return True
    _factor_coupling_block(a, low, 0, 2)
    if not _factor_diagonal_block(a, low, shift, 2, 4, 0, 2):
        return False
    for b in range(2, nb):
        r0 = block_start(b)
        _factor_coupling_block(a, low, r0 - 4, 4)
        if not _factor_diagonal_block(a, low, shift, r0, 4, r0 - 4, 4):
            return False
    return True


@kernel(inline="always")
def _forward_block(low, out, r0, m, q0, qm):
    """Column-oriented forward substitution through block ``r0`` (size ``m``).

    Each solved entry is subtracted at once from the rows below it in its own block and in the
    next (at ``q0``, size ``qm``): independent updates instead of one long dependent sum.
    """
    for j in range(m):
        rj = r0 + j
        v = out[rj] * low[rj, rj]
        out[rj] = v
        for i in range(j + 1, m):
            out[r0 + i] -= low[r0 + i, rj] * v
        for i in range(qm):
            out[q0 + i] -= low[q0 + i, rj] * v


@kernel(inline="always")
def _backward_block(low, out, r0, m, q0, qm):
    """Back substitution with ``Lᵀ`` through block ``r0`` (size ``m``), next block at ``q0``."""
    for back in range(m):
        i = m - 1 - back
        ri = r0 + i
        below = 0.0
        for k in range(qm):
            below += low[q0 + k, ri] * out[q0 + k]
        own = 0.0
        for k in range(i + 1, m):
            own += low[r0 + k, ri] * out[r0 + k]
        out[ri] = (out[ri] - below - own) * low[ri, ri]


@kernel
def cholesky_solve(low, b, out, n):
    """Solve ``L Lᵀ out = b`` given the block factor ``low`` from :func:`cholesky`.

    ``b`` is read only to copy it into ``out``, so both may be the same array (in place).
    """
    nb = n_blocks(n)
    for i in range(n):
        out[i] = b[i]
    if nb == 1:
        _forward_block(low, out, 0, 2, 0, 0)
        _backward_block(low, out, 0, 2, 0, 0)
        return
    _forward_block(low, out, 0, 2, 2, 4)
    for blk in range(1, nb - 1):
        r0 = block_start(blk)
        _forward_block(low, out, r0, 4, r0 + 4, 4)
    last = block_start(nb - 1)
    _forward_block(low, out, last, 4, 0, 0)
    _backward_block(low, out, last, 4, 0, 0)
    for blk in range(nb - 2, 0, -1):
        r0 = block_start(blk)
        _backward_block(low, out, r0, 4, r0 + 4, 4)
    _backward_block(low, out, 0, 2, 2, 4)


@kernel(inline="always")
def band_matvec_add(a, x, n, band, out):
    """``out[:n] += a[:n, :n] @ x[:n]`` for ``a`` vanishing outside ``|i - j| <= band``.

    Each row's sum runs in three interleaved partial sums: one running sum is a chain of
    dependent additions (four cycles each), three let them overlap. In Rodas4 on the
    pick-and-place finger this took the product from 12 % of the run time to about 6 %.
    """
    for i in range(n):
        row = a[i]
        lo = max(0, i - band)
        hi = min(n, i + band + 1)
        acc0 = out[i]
        acc1 = 0.0
        acc2 = 0.0
        j = lo
        while j + 2 < hi:
            acc0 += row[j] * x[j]
            acc1 += row[j + 1] * x[j + 1]
            acc2 += row[j + 2] * x[j + 2]
            j += 3
        while j < hi:
            acc0 += row[j] * x[j]
            j += 1
        out[i] = acc0 + (acc1 + acc2)


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
