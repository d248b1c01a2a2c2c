"""Numba kernels: arrays in, arrays out, no Python objects.

Modules
-------
_jit
    The project's one JIT policy (``cache=True``, ``nogil``, ``parallel`` only on batch kernels).
layout
    Column indices of the per-unit parameter table and the node numbering shared by all kernels.
lattice
    Energy, analytic gradient and analytic Hessian of the spring lattice (MODEL.md §5).
linalg
    Small dense Cholesky factorisation and solves used by the Newton solver.
newton
    Globalised Newton minimisation with a caller-set tolerance and iteration cap.
tables
    Status codes, per-unit tables and their derivative tables of a batch of designs, in one
    compiled pass over a constants set (``model.constants_set``) and the beam constants.
states
    Geometric guess, stable-state search and per-state outputs (MODEL.md §6-§7).
batch
    ``prange`` entry points evaluating many designs on the kernels above (and their serial
    twins for small batches).
sensitivity, sensitivity_batch
    Design sensitivities of a stable state by the implicit function theorem (forward-mode
    tangent assembly, third-derivative contraction), and their batch entry points.
dynamics
    Right-hand side of the damped lattice under pressure (MODEL.md §8) and its Jacobians.
dense_lu
    Banded LU with partial pivoting for the (unsymmetric) stage matrices of the integrators.
integrators_rosenbrock, integrators_explicit
    Rodas4 (full and overdamped models) and Dormand-Prince 5(4), with step and time caps.
events
    Dense-output event location: snap-through, snap-back and reset times.
reduced
    The release model: a cheaper reset-time model with its error measured.
dynamics_batch
    ``prange`` entry point for reset times of many designs.
bordered_lu, continuation, landing, snap, snap_steps, snap_records
    Equilibrium branches under a slow pressure ramp (bordered banded LU, pseudo-arclength
    continuation, folds, crossings), landings after a snap by the equations of motion, and
    the snap pressures of one design or many (``prange``): the walk, its step's stages, and
    its output layout and records.
shell, shell_linalg, shell_path
    The unit-cell shell model of one dome (:mod:`dpfexplore.unitcell`): energy, gradient and
    exact Hessian of the discretised meridian, banded LU with an inertia count, and the
    continuation of its equilibrium path under apex displacement control.
closed_form_loops
    The closed forms of many domes, by a constants set and by the paper's compiled forms
    (``bench identify``).
"""
