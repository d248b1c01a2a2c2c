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
where a plain tuple of arrays is typed by its C fast path, several times faster for the row
kernels' records (measured: `docs/decisions.md`). The
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

One sub-package per family of kernels, named by what it computes, and at the top the modules
every family reads. Imports between the families point one way: ``linalg`` and ``tables``
import no other family; ``statics``, ``dynamics`` and ``shell`` build on ``linalg`` (and the
lattice); ``sensitivity`` on ``statics`` and ``tables``; ``reset`` on ``statics`` and
``dynamics``; ``snap`` on ``dynamics`` and ``reset``. A kernel inlines its callees, so an edit
of one module can change kernels compiled in another: the on-disk cache is keyed to a digest
of every source the kernels compile (:mod:`._jit`), and a stale cache is cleared before
anything loads.

Modules
-------
_jit
    The project's one JIT policy (``cache=True``, ``nogil``, ``parallel`` only on batch
    kernels), and the on-disk cache kept in step with the sources.
records
    The named records kernels take and fill (lattices, controls, knots, physics, outputs).
layout
    Column indices of the per-unit parameter table and the node numbering shared by all kernels.
lattice
    Energy, analytic gradient and analytic Hessian of the spring lattice (MODEL.md §5).
linalg
    Block-tridiagonal Cholesky, banded LU with threshold pivoting, bordered banded LU, and
    band-storage LU with an inertia count (the shell).
tables
    Status codes, per-unit tables and their derivative tables of a batch of designs, in one
    compiled pass over a constants set (``model.constants_set``) and the beam constants; the
    closed forms over many domes (``bench identify``).
statics
    Newton minimisation, stable-state search, per-state outputs (MODEL.md §6-§7) and the
    ``prange`` batch entry points with their serial twins.
sensitivity
    Design sensitivities of a stable state by the implicit function theorem, and their batch
    entry points.
dynamics
    The equations of motion under pressure (MODEL.md §8) and their Jacobians, the integrators
    (Rodas4, Dormand-Prince 5(4)), events, and the ``prange`` batch of reset times.
reset
    The release and fast reset models: reset times without integrating the whole pulse.
snap
    Snap pressures under a slow pressure ramp: pseudo-arclength continuation, folds, landings
    after a snap, the walk over one design or many (``prange``).
shell
    The unit-cell shell model of one dome (:mod:`dpfexplore.unitcell`): energy, gradient and
    exact Hessian of the discretised meridian, and its equilibrium path under apex
    displacement control.
"""
