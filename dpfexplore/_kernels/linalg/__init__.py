"""Dense and banded linear algebra of the kernels, written out for small matrices (Numba).

Modules
-------
cholesky
    Block-tridiagonal Cholesky factorisation and solves for the lattice Hessian (Newton,
    sensitivities, symmetric stage matrices), and banded matrix-vector products.
banded_lu
    Banded LU with threshold pivoting in dense storage: the lattice's unsymmetric stage and
    equilibrium matrices (at most 46 square).
bordered_lu
    LU of a banded matrix bordered by one dense row and column: the continuation's corrector.
band_storage
    Banded LU with partial pivoting in band storage, and the inertia of a symmetric band: the
    unit-cell shell, whose matrices have hundreds of rows.
"""
