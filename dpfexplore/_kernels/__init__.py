"""Numba kernels: arrays in, arrays out, no Python objects.

Modules
-------
layout
    Column indices of the per-unit parameter table and the node numbering shared by all kernels.
lattice
    Energy, analytic gradient and analytic Hessian of the spring lattice (MODEL.md §5).
linalg
    Small dense Cholesky factorisation and solves used by the Newton solver.
newton
    Globalised Newton minimisation with a caller-set tolerance and iteration cap.
states
    Geometric guess, stable-state search and per-state outputs (MODEL.md §6-§7).
batch
    ``prange`` entry points evaluating many designs on the kernels above.
"""
