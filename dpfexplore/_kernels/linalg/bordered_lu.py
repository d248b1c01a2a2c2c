"""LU of a banded matrix bordered by one dense row and column, in place (Numba).

The continuation's corrector solves with ``[[K, c], [rᵀ, δ]]``: the lattice's banded Jacobian
``K`` (half-bandwidth 7, :data:`.linalg.banded_lu.LATTICE_HALF_BANDWIDTH`) bordered by the pressure
column and the arclength row. A dense LU of it costs ``m³/3`` (20 µs at N = 8, 50 µs at N = 12
against 3-10 µs for assembling ``K``); eliminating inside the band costs ``m b²``.

Why not block elimination (bordering): solving with ``K``'s own factors is unstable where ``K``
is singular, which is exactly where the continuation works hardest (folds). So the border row
stays a pivot candidate, as in a dense LU with threshold pivoting: the diagonal entry is kept
unless it is below :data:`.linalg.banded_lu.PIVOT_THRESHOLD` of the largest candidate, the
candidates being the band's rows below it *and* the border row. Away from folds the diagonal wins
and the band is kept (row interchanges inside the band widen ``U`` to ``2b``, as in
:mod:`.linalg.banded_lu`). When the border row wins (``K``'s singular direction, near a fold) it
becomes a dense pivot row and fills every row below it: from that column on the elimination is
dense. The column where that happened is stored after the pivots (``piv[m]``; ``m`` when it did
not).
"""

from __future__ import annotations

import math

from .._jit import kernel
from .banded_lu import column_max, eliminate_row, threshold_pivot


@kernel(inline="always")
def _eliminate(row_i, row_k, k, inv, col_end, last, pivot_last):
    """Row ``i`` minus its multiple of pivot row ``k`` (columns up to ``col_end`` and ``last``)."""
    lik = eliminate_row(row_i, row_k, k, inv, col_end)
    if lik != 0.0:
        row_i[last] -= lik * pivot_last


@kernel
def bordered_factor(a, m, piv, band):
    """Factor ``a[:m, :m]`` in place: band ``|i - j| <= band`` plus the last row and column.

    ``piv`` (int64, at least ``m + 1``) receives the row interchanges and, in ``piv[m]``, the
    first column eliminated densely. On return ``a`` holds ``L`` below the diagonal, ``U`` above
    it and ``U``'s reciprocal pivots on it. Returns 0, or 1 if a pivot is zero or not finite.
    """
    last = m - 1
    dense_from = m
    wide = False
    for k in range(last):
        dense = k >= dense_from
        band_end = last if dense else min(last, k + band + 1)  # band rows k..band_end-1
        diag = abs(a[k, k])
        big, p = column_max(a, k, k + 1, band_end, diag, k)
        big, p = column_max(a, k, last, m, big, p)  # the border row
        p = threshold_pivot(diag, big, p, k)
        if p < 0:
            return 1
        piv[k] = p
        if p == last and not dense:
            dense_from = k
            dense = True
            band_end = last
        elif p != k:
            wide = True
        if p != k:
            row_k = a[k]
            row_p = a[p]
            for j in range(k, m):
                tmp = row_k[j]
                row_k[j] = row_p[j]
                row_p[j] = tmp
        row_k = a[k]
        inv = 1.0 / row_k[k]
        row_k[k] = inv
        col_end = last if dense else min(last, k + (2 * band if wide else band) + 1)
        pivot_last = row_k[last]
        for i in range(k + 1, band_end):  # band rows (all rows once dense)
            _eliminate(a[i], row_k, k, inv, col_end, last, pivot_last)
        _eliminate(a[last], row_k, k, inv, col_end, last, pivot_last)  # the border row
    piv[last] = last
    piv[m] = dense_from
    pivot = a[last, last]
    if pivot == 0.0 or not math.isfinite(pivot):
        return 1
    a[last, last] = 1.0 / pivot
    return 0


@kernel
def bordered_solve(a, m, piv, b, band):
    """Solve ``A z = b`` in place in ``b`` with the factors of :func:`bordered_factor`."""
    last = m - 1
    dense_from = piv[m]
    upper = band
    for k in range(last):
        if piv[k] != k and piv[k] != last:
            upper = 2 * band
    for k in range(last):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        bk = b[k]
        if k >= dense_from:
            for i in range(k + 1, m):
                b[i] -= a[i, k] * bk
        else:
            for i in range(k + 1, min(last, k + band + 1)):
                b[i] -= a[i, k] * bk
            b[last] -= a[last, k] * bk
    for i in range(last, -1, -1):
        s = b[i]
        if i >= dense_from or i == last:
            for j in range(i + 1, m):
                s -= a[i, j] * b[j]
        else:
            for j in range(i + 1, min(last, i + upper + 1)):
                s -= a[i, j] * b[j]
            s -= a[i, last] * b[last]
        b[i] = s * a[i, i]
