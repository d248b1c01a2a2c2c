"""Banded LU factorisation with threshold pivoting, in dense storage, in place (Numba).

The stiff integrators solve with ``M/(hγ)² + C/(hγ) + H + D - P_J``: symmetric parts (mass,
damping, Hessian) plus the non-symmetric pressure-follower and damping-position Jacobians, so a
Cholesky factorisation does not apply. The matrices are at most ``4·12 - 2 = 46`` square and
banded: in the free-coordinate order ``D1, D2, L2, D3, L3, ...`` every spring, torsion, dashpot
and pressure face couples nodes at most three places apart, so the half-bandwidth is 7
(:data:`LATTICE_HALF_BANDWIDTH`). Dense storage keeps the code plain; no allocation, no LAPACK
call, so the kernels stay ``nogil``. ``band >= n - 1`` gives an ordinary dense LU.

Why threshold pivoting
    Partial pivoting (always the largest entry of the column) widens ``U`` to twice the band
    (as in LAPACK's ``gbtrf``) whenever it swaps rows. These matrices are dominated by their
    diagonal almost always, so the diagonal entry is kept as pivot unless it is smaller than
    :data:`PIVOT_THRESHOLD` times the largest entry below it (threshold partial pivoting, as in
    sparse direct solvers such as MA48 or UMFPACK, whose default threshold this is). The
    multipliers stay below ``1/0.1 = 10`` in magnitude; as long as no row is swapped, ``U``
    keeps the band and the elimination skips the zeros beyond it.
Why reciprocal pivots and column-oriented back substitution
    At these sizes a solve is a chain of dependent operations: the division by each pivot and
    a dot product per row that must wait for the previous row. :func:`lu_factor` stores the
    *reciprocal* pivots on the diagonal (a multiplication instead of a division on the chain),
    and :func:`lu_solve` subtracts each solved entry from the rows above at once (independent
    updates). Together with the narrower ``U`` this shortens Rodas4's steps on stiff fingers
    without changing a result.
One rule for the lattice's LUs
    The continuation's bordered LU (:mod:`.linalg.bordered_lu`) factors the same band with a
    border row and column by the same rule: both choose a pivot with :func:`column_max` and
    :func:`threshold_pivot` and eliminate with :func:`eliminate_row` (compiled inline, so
    neither pays a call). The shell's LU (:mod:`.linalg.band_storage`) does the same job on
    other matrices and stays apart: it says why.
"""

from __future__ import annotations

import math

from .._jit import kernel

#: Half-bandwidth of every matrix the lattice assembles, in free coordinates.
LATTICE_HALF_BANDWIDTH = 7


#: Smallest ratio of the kept diagonal pivot to the largest entry below it in its column.
PIVOT_THRESHOLD = 0.1


@kernel(inline="always")
def column_max(a, k, first, end, big, p):
    """The largest ``|a[i, k]|`` of rows ``first..end-1`` if above ``big``, and its row.

    Starts from ``(big, p)``; the first of equal entries wins.
    """
    for i in range(first, end):
        v = abs(a[i, k])
        if v > big:
            big = v
            p = i
    return big, p


@kernel(inline="always")
def threshold_pivot(diag, big, p, k):
    """The pivot row of column ``k``: ``k`` unless ``|a_kk| = diag < PIVOT_THRESHOLD · big``.

    ``big`` is the largest candidate's magnitude, in row ``p``. Returns -1 if it is zero or not
    finite (the matrix is singular to working precision).
    """
    if not (big > 0.0) or not math.isfinite(big):
        return -1
    if diag >= PIVOT_THRESHOLD * big:
        return k
    return p


@kernel(inline="always")
def eliminate_row(row_i, row_k, k, inv, end):
    """Row ``i`` minus its multiple of pivot row ``k`` in columns ``k+1..end-1``.

    ``inv`` is the reciprocal pivot; the multiplier is stored in ``row_i[k]`` and returned.
    """
    lik = row_i[k] * inv
    row_i[k] = lik
    if lik != 0.0:
        for j in range(k + 1, end):
            row_i[j] -= lik * row_k[j]
    return lik


@kernel
def lu_factor(a, n, piv, band):
    """Factor the leading ``n x n`` block of ``a`` in place (``P A = L U``, unit lower ``L``).

    ``a`` must vanish outside ``|i - j| <= band``. ``piv`` (int64, ``n``) receives the row
    interchanges. On return ``a`` holds the multipliers of ``L`` below the diagonal, ``U``
    above it and the reciprocals of ``U``'s diagonal on it (only :func:`lu_solve` reads them).
    Returns 0 on success, 1 if a pivot is zero or not finite (singular matrix).
    """
    wide = False  # after the first row interchange U may reach twice the band
    for k in range(n):
        last_row = min(n, k + band + 1)
        diag = abs(a[k, k])
        big, p = column_max(a, k, k + 1, last_row, diag, k)
        p = threshold_pivot(diag, big, p, k)
        if p < 0:
            return 1
        piv[k] = p
        row_k = a[k]
        if p != k:
            wide = True
            row_p = a[p]
            for j in range(k, min(n, k + 2 * band + 1)):
                tmp = row_k[j]
                row_k[j] = row_p[j]
                row_p[j] = tmp
        end = min(n, k + (2 * band if wide else band) + 1)
        inv = 1.0 / row_k[k]
        row_k[k] = inv
        for i in range(k + 1, last_row):
            eliminate_row(a[i], row_k, k, inv, end)
    return 0


@kernel
def lu_solve(a, n, piv, b, band):
    """Solve ``A z = b`` in place in ``b`` with the factors of :func:`lu_factor`.

    The row interchanges are applied as the elimination went (``L`` stays within the band),
    then ``U`` (upper bandwidth ``band``, or ``2 band`` if any row was interchanged) is
    back-substituted column by column.
    """
    upper = band
    for k in range(n):
        if piv[k] != k:
            upper = 2 * band
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        bk = b[k]
        for i in range(k + 1, min(n, k + band + 1)):
            b[i] -= a[i, k] * bk
    for i in range(n - 1, -1, -1):
        bi = b[i] * a[i, i]
        b[i] = bi
        for r in range(max(0, i - upper), i):
            b[r] -= a[r, i] * bi
