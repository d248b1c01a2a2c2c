"""Dense and banded linear algebra of the kernels, written out for small matrices (Numba).

Four factorisations for four kinds of matrix; each module says why it is not another's.

Modules
-------
cholesky
    Block-tridiagonal Cholesky factorisation and solves for the lattice Hessian (Newton,
    sensitivities, symmetric stage matrices), and banded matrix-vector products: symmetric
    positive definite matrices, no pivoting.
banded_lu
    Banded LU with threshold pivoting in dense storage: the lattice's unsymmetric stage and
    equilibrium matrices (at most 46 square). Its pivot choice and row elimination are shared
    with the bordered LU.
bordered_lu
    LU of that band bordered by one dense row and column, by the same rule: the continuation's
    corrector.
band_storage
    Banded LU with partial pivoting in band storage, and the inertia of a symmetric band: the
    unit-cell shell, whose matrices have hundreds of rows.
"""
