"""Numba kernels: arrays in, arrays out, no Python objects.

Arguments that travel together reach a kernel as one named record: the lattice
(``Lattice``, ``LatticeBatch``, ``DesignTable``), the Newton controls (``NewtonControls``), the
pressure knots (``PressureKnots``), the model of motion (``Physics``, ``MotionModel``), and what a
kernel writes (``StateRows``, ``ResetRows``, ``RunRecord``, ...). Records are
``collections.namedtuple`` classes of arrays and scalars defined at module level in
:mod:`.records` (or beside the one family that uses them: :mod:`.snap.records`,
:mod:`.shell.records`): Numba compiles them as structs at no run-time cost, and ``cache=True``
finds a record's type again in a later process through its importable class. The Python callers
build them with scalars of a fixed type, so one record type is one compiled signature; a kernel
unpacks a record by name or position at its top, and the ``prange`` entry points and their
serial twins take the same records.

Records at the entry points. Inside compiled code a record costs nothing, but a call from
Python pays for typing its arguments, and Numba types a named tuple in Python, field by field,
where a plain tuple of arrays is typed by its C fast path: the row kernels' four records took
2.9 µs to dispatch against 0.7 µs as plain tuples (one-row call, `docs/decisions.md`). The
entry points that every :func:`~dpfexplore.solvers.statics.solve_batch` call enters
(:func:`.tables.design_tables.design_tables`, :func:`.statics.batch.solve_rows` and
:func:`.sensitivity.batch.solve_rows_sensitivities` with their serial twins) therefore take
each record as a plain tuple of its fields, in the record's order, and name it on entry
(``DesignTable(*designs)``, :func:`.statics.batch.name_row_records`); the callers write the record's
name beside the tuple. Kernels entered once per long computation (integrators, continuation,
the shell's path) take the named records themselves.

Integer and boolean constants passed from one kernel to another are ``np.int64`` values (module
constants such as ``RISING``, ``MAX_ITER``), never Python literals: Numba types a literal argument
as ``Literal[int](value)`` and compiles the callee once more for each literal value it meets, so
``follow(..., 1, ...)`` and ``follow(..., -1, ...)`` would be two compilations of the same code.

The package stays one flat folder of modules although it holds more than the ~15 modules
the other packages keep to: :mod:`._jit` keys the whole on-disk Numba cache to one digest of
this folder's sources (a kernel inlines its callees, so an edit anywhere may change any
compiled kernel), and sub-packages would only hide that they are one compilation unit.

Modules
-------
_jit
    The project's one JIT policy (``cache=True``, ``nogil``, ``parallel`` only on batch kernels).
records
    The named records kernels take and fill (lattices, controls, knots, physics, outputs).
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
shell, shell_linalg, shell_path, shell_records
    The unit-cell shell model of one dome (:mod:`dpfexplore.unitcell`): energy, gradient and
    exact Hessian of the discretised meridian, banded LU with an inertia count, the
    continuation of its equilibrium path under apex displacement control, and the records they
    pass (the shell's geometry, the path's controls, scratch and points).
closed_form_loops
    The closed forms of many domes, by a constants set and by the paper's compiled forms
    (``bench identify``).
"""
