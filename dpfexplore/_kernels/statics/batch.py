"""Batch entry points: many design-states evaluated in parallel on the per-design kernels.

Parallelism is Numba's ``prange`` over blocks of rows. Each block allocates its own workspace,
and the per-design kernels write only to their own row of the outputs, so blocks share nothing
mutable. The kernels are ``nogil``, but the batch function itself must not be entered from several
Python threads at once under Numba's default ``workqueue`` threading layer (that layer is not
thread-safe and aborts); sweeps therefore run one batch call per process at a time, and the Dask
engine uses worker processes with one thread each.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ...model import status as st
from ...model.domain import MAX_UNITS
from .._jit import batch_kernel, kernel
from ..layout import n_free
from ..records import DesignTable, Lattice, NewtonControls, RowPlan, StateRows
from .newton import workspace
from .states import N_OUT, solve_state, state_body

#: Rows per parallel block: large enough to amortise the workspace allocation, small enough to
#: balance load when collapsed states (several attempts) cluster.
BLOCK_ROWS = 16


@kernel
def _solve_rows(designs, rows, first, last, controls, outputs):
    """Solve rows ``first`` to ``last - 1`` (arguments as :func:`solve_rows`)."""
    ws = workspace()
    x = np.empty(n_free(MAX_UNITS))
    unit_params, h, n_units, design_status = designs
    out, status, found, n_iter, shapes = outputs
    keep_shape = shapes.shape[1] > 0
    for r in range(first, last):
        i = rows.design[r]
        if design_status[i] != st.OK:
            status[r] = design_status[i]
            found[r] = -1
            n_iter[r] = 0
            out[r, :] = np.nan
            continue
        up = unit_params[i, : n_units[i]]
        s, f, it = state_body(
            Lattice(up, h[i]),
            rows.state[r],
            controls,
            rows.want_stiffness,
            rows.want_min_eig,
            x,
            out[r],
            ws,
        )
        status[r] = s
        found[r] = f
        n_iter[r] = it
        if keep_shape:
            nf = n_free(n_units[i])
            for j in range(shapes.shape[1]):
                shapes[r, j] = x[j] if j < nf else np.nan


@kernel(inline="always")
def name_row_records(designs, rows, controls, outputs):
    """The row entry points' records from the plain tuples they are called with.

    Package docstring, "Records at the entry points".
    """
    return DesignTable(*designs), RowPlan(*rows), NewtonControls(*controls), StateRows(*outputs)


@batch_kernel
def _solve_rows_parallel(designs, rows, controls, outputs):
    """Every row, blocks of rows in parallel (records as :func:`solve_rows` names them)."""
    n_rows = rows.design.shape[0]
    n_blocks = (n_rows + BLOCK_ROWS - 1) // BLOCK_ROWS
    for b in prange(n_blocks):
        first = b * BLOCK_ROWS
        last = min(first + BLOCK_ROWS, n_rows)
        _solve_rows(designs, rows, first, last, controls, outputs)


@kernel
def solve_rows(designs, rows, controls, outputs):
    """Solve every (design, state) row in parallel.

    Each argument is a plain tuple of its record's fields, in order (:mod:`.records`), named
    here and handed to the ``prange`` kernel (Numba's parfor lowering does not take records
    built inside the parallel function itself).

    Parameters
    ----------
    designs : DesignTable fields
        The batch's kernel tables and status codes; rows of designs whose status is not ``OK``
        are copied through with NaN outputs.
    rows : RowPlan fields
        Design and requested state of each row, and which optional outputs to compute.
    controls : NewtonControls fields
        Newton controls.
    outputs : StateRows fields
        Receive each row's outputs, status, state found, iterations and (when not empty) shape.
    """
    table, plan, newton, written = name_row_records(designs, rows, controls, outputs)
    _solve_rows_parallel(table, plan, newton, written)


@kernel
def solve_rows_serial(designs, rows, controls, outputs):
    """:func:`solve_rows` on the calling thread, for small batches.

    Starting a parallel region wakes the worker threads, which costs from tens of microseconds on
    an idle machine to milliseconds on a loaded one: more than a few designs' solves. Same
    arguments and results as :func:`solve_rows`.
    """
    table, plan, newton, written = name_row_records(designs, rows, controls, outputs)
    _solve_rows(table, plan, np.int64(0), plan.design.shape[0], newton, written)


@kernel
def solve_repeatedly(lattice, requested, controls, want_stiffness, want_min_eig, repeats):
    """Solve one design-state ``repeats`` times (for timing single designs); returns the status.

    ``lattice`` is a :class:`~.records.Lattice`, ``controls`` :class:`~.records.NewtonControls`.
    Workspace and outputs are allocated once, as in :func:`solve_rows`, so the time per repeat
    is the solver's own.
    """
    ws = workspace()
    x = np.empty(n_free(MAX_UNITS))
    out = np.empty(N_OUT)
    status = 0
    for _ in range(repeats):
        status, _, _ = solve_state(
            lattice, requested, controls, want_stiffness, want_min_eig, x, out, ws
        )
    return status


__all__ = ["N_OUT", "solve_repeatedly", "solve_rows", "solve_rows_serial"]
