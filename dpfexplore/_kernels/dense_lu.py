"""Banded LU factorisation with partial pivoting, in dense storage, in place (Numba).

The stiff integrators solve with ``M/(hγ)² + C/(hγ) + H + D - P_J``: symmetric parts (mass,
damping, Hessian) plus the non-symmetric pressure-follower and damping-position Jacobians, so a
Cholesky factorisation does not apply. The matrices are at most ``4·12 - 2 = 46`` square and
banded: in the free-coordinate order ``D1, D2, L2, D3, L3, ...`` every spring, torsion, dashpot
and pressure face couples nodes at most three places apart, so the half-bandwidth is 7
(:data:`LATTICE_HALF_BANDWIDTH`). Partial pivoting keeps ``L`` within the lower band and widens
``U`` to at most twice the band (as in LAPACK's ``gbtrf``). Dense storage keeps the code plain;
skipping the zeros makes it 2x faster than a dense LU at ``N = 6`` and 3x at ``N = 12``
(measured in Numba on these matrices); no allocation, no LAPACK call, so the kernels stay
``nogil``. ``band >= n - 1`` gives an ordinary dense LU.
"""

from __future__ import annotations

import math

from .._jit import kernel

#: Half-bandwidth of every matrix the lattice assembles, in free coordinates.
LATTICE_HALF_BANDWIDTH = 7


@kernel
def lu_factor(a, n, piv, band):
    """Factor the leading ``n x n`` block of ``a`` in place (``P A = L U``, unit lower ``L``).

    ``a`` must vanish outside ``|i - j| <= band``. ``piv`` (int64, ``n``) receives the row
    interchanges. Returns 0 on success, 1 if a pivot is zero or not finite (singular matrix).
    """
    for k in range(n):
        last_row = min(n, k + band + 1)
        p = k
        big = abs(a[k, k])
        for i in range(k + 1, last_row):
            v = abs(a[i, k])
            if v > big:
                big = v
                p = i
        piv[k] = p
        if not (big > 0.0) or not math.isfinite(big):
            return 1
        end = min(n, k + 2 * band + 1)
        row_k = a[k]
        if p != k:
            row_p = a[p]
            for j in range(k, end):
                tmp = row_k[j]
                row_k[j] = row_p[j]
                row_p[j] = tmp
        inv = 1.0 / row_k[k]
        for i in range(k + 1, last_row):
            row_i = a[i]
            lik = row_i[k] * inv
            row_i[k] = lik
            if lik != 0.0:
                for j in range(k + 1, end):
                    row_i[j] -= lik * row_k[j]
    return 0


@kernel
def lu_solve(a, n, piv, b, band):
    """Solve ``A z = b`` in place in ``b`` with the factors of :func:`lu_factor`.

    The row interchanges are applied as the elimination went (``L`` stays within the band),
    then ``U`` (upper bandwidth ``2 band``) is back-substituted.
    """
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        bk = b[k]
        if bk != 0.0:
            for i in range(k + 1, min(n, k + band + 1)):
                b[i] -= a[i, k] * bk
    for i in range(n - 1, -1, -1):
        row = a[i]
        s = b[i]
        for j in range(i + 1, min(n, i + 2 * band + 1)):
            s -= row[j] * b[j]
        b[i] = s / row[i]
