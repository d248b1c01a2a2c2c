"""Banded linear algebra of the shell kernels (Numba): LU with partial pivoting, inertia.

The shell's Hessian is banded (half-bandwidth :data:`.shell.energy.BAND`); the continuation's
Jacobian is that band with one row replaced by a unit row (the local parametrisation,
:mod:`.shell.path`) and shifted so that the whole matrix stays banded. Both are factored here in
``O(m b²)``.

Storage: element ``(i, j)`` of a matrix with lower/upper bandwidths ``kl, ku`` lives at
``w[i, j - i + kl]``; ``w`` has ``2 kl + ku + 1`` columns, room for the fill that row
interchanges bring (LAPACK's ``gbtrf`` keeps the same fill, column-wise).

Why not the lattice's banded LU (:mod:`.linalg.banded_lu`)
    Both factor a banded matrix, but not the same matrices. The shell's have hundreds of rows
    (two unknowns per node of a meridian of 128 elements by default, more on finer meshes), so
    they are stored as bands: the lattice's dense ``m x m`` storage, right for its at most 46
    rows, would cost ``m²`` memory and zeroing per factorisation here. The rule differs too:
    above the parameter's unit row the continuation's Jacobian holds the Hessian's rows shifted
    up by one, so its diagonal carries the Hessian's sub-diagonal and is not dominant, the
    premise of the lattice's threshold pivoting; this LU takes the largest entry of each column
    (partial pivoting, LAPACK's rule), whose fill the band storage holds anyway. Either LU in
    the other's place would change the unit-cell curves or the lattice's results in their last
    bits.
Why the inertia count eliminates without pivoting
    :func:`negative_pivots` does another job: the signs of the pivots of a symmetric matrix
    (Sylvester's law of inertia), which any row interchange would spoil.
"""

from __future__ import annotations

from .._jit import kernel


@kernel
def band_lu(w, m, kl, ku, piv):
    """Factor the banded ``w`` (``m`` rows) in place with partial pivoting.

    ``piv[k]`` receives the row swapped into row ``k``. Returns 0, or 1 if a pivot is zero or
    not finite (the matrix is singular to working precision).
    """
    width = kl + ku  # columns right of the diagonal after fill
    for k in range(m):
        last = min(m - 1, k + kl)
        p = k
        big = abs(w[k, kl])
        for i in range(k + 1, last + 1):
            v = abs(w[i, k - i + kl])
            if v > big:
                big = v
                p = i
        piv[k] = p
        if not big > 0.0 or big != big or big == float("inf"):
            return 1
        end = min(m - 1, k + width)
        if p != k:
            for j in range(k, end + 1):
                a = w[k, j - k + kl]
                w[k, j - k + kl] = w[p, j - p + kl]
                w[p, j - p + kl] = a
        inv = 1.0 / w[k, kl]
        for i in range(k + 1, last + 1):
            lik = w[i, k - i + kl] * inv
            w[i, k - i + kl] = lik
            if lik != 0.0:
                for j in range(k + 1, end + 1):
                    w[i, j - i + kl] -= lik * w[k, j - k + kl]
    return 0


@kernel
def band_lu_solve(w, m, kl, ku, piv, b):
    """Solve with the factors of :func:`band_lu`, overwriting ``b`` with the solution."""
    width = kl + ku
    for k in range(m):
        p = piv[k]
        if p != k:
            a = b[k]
            b[k] = b[p]
            b[p] = a
        bk = b[k]
        if bk != 0.0:
            for i in range(k + 1, min(m - 1, k + kl) + 1):
                b[i] -= w[i, k - i + kl] * bk
    for k in range(m - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, min(m - 1, k + width) + 1):
            s -= w[k, j - k + kl] * b[j]
        b[k] = s / w[k, kl]


@kernel
def band_solve(band, w, piv, b):
    """Solve ``A x = b`` for ``A`` in band storage, ``b`` overwritten by ``x``; 0, or -1.

    ``band`` holds the rows of ``A`` in band storage (``(m, 2 bw + 1)``, the diagonal in column
    ``bw``); ``w`` (``(m, 3 bw + 1)``) and ``piv`` are scratch. Returns -1 when the
    factorisation meets a zero pivot (``b`` unsolved then).
    """
    m = b.shape[0]
    bw = (band.shape[1] - 1) // 2
    w[:, :] = 0.0
    for i in range(m):
        for k in range(-bw, bw + 1):
            if 0 <= i + k < m:
                w[i, k + bw] = band[i, bw + k]
    if band_lu(w, m, bw, bw, piv) != 0:
        return -1
    band_lu_solve(w, m, bw, bw, piv, b)
    return 0


@kernel
def band_newton_step(band, g, y, w, piv, b):
    """One Newton step on a band Hessian: ``y -= H⁻¹ g`` in place; the step's largest entry.

    ``band`` holds the Hessian (as :func:`band_solve`), ``g`` the gradient; ``w``, ``piv`` and
    ``b`` are scratch. Returns the largest absolute entry of the step (inf when the step
    overflows), or -1.0 when the factorisation meets a zero pivot (``y`` unchanged then).
    """
    m = y.shape[0]
    for j in range(m):
        b[j] = -g[j]
    if band_solve(band, w, piv, b) != 0:
        return -1.0
    dn = 0.0
    for j in range(m):
        y[j] += b[j]
        dn = max(dn, abs(b[j]))
    return dn


@kernel
def negative_pivots(band, lo, bw, work):
    """Inertia of the symmetric band ``band[lo:, lo:]``: the number of negative eigenvalues.

    Gaussian elimination without pivoting keeps the band and, by Sylvester's law of inertia,
    its pivots have the signs of the eigenvalues. ``band[i, bw + j - i]`` holds element
    ``(i, j)``; ``work`` is scratch of the same shape. Returns -1 if a pivot is exactly zero or
    not finite (singular: neither count is meaningful there).
    """
    m = band.shape[0]
    work[:, :] = band
    count = 0
    for k in range(lo, m):
        d = work[k, bw]
        if d == 0.0 or d != d or abs(d) == float("inf"):
            return -1
        if d < 0.0:
            count += 1
        end = min(m - 1, k + bw)
        for i in range(k + 1, end + 1):
            lik = work[i, bw + k - i] / d
            if lik != 0.0:
                for j in range(k + 1, end + 1):
                    work[i, bw + j - i] -= lik * work[k, bw + j - k]
    return count
