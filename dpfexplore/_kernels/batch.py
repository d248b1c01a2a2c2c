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

from ..model import status as st
from ..model.domain import MAX_UNITS
from ._jit import batch_kernel, kernel
from .layout import n_free
from .newton import workspace
from .states import N_OUT, solve_state

#: Rows per parallel block: large enough to amortise the workspace allocation, small enough to
#: balance load when collapsed states (several attempts) cluster.
BLOCK_ROWS = 16


@kernel
def _solve_rows(
    unit_params,
    h,
    n_units,
    design_status,
    row_design,
    row_state,
    first,
    last,
    gtol,
    xtol,
    max_iter,
    max_step,
    want_stiffness,
    want_min_eig,
    out,
    status,
    found,
    n_iter,
    shapes,
):
    ws = workspace()
    x = np.empty(n_free(MAX_UNITS))
    keep_shape = shapes.shape[1] > 0
    for r in range(first, last):
        i = row_design[r]
        if design_status[i] != st.OK:
            status[r] = design_status[i]
            found[r] = -1
            n_iter[r] = 0
            out[r, :] = np.nan
            continue
        up = unit_params[i, : n_units[i]]
        s, f, it = solve_state(
            up,
            h[i],
            row_state[r],
            gtol,
            xtol,
            max_iter,
            max_step,
            want_stiffness,
            want_min_eig,
            x,
            out[r],
            ws,
        )
        status[r] = s
        found[r] = f
        n_iter[r] = it
        if keep_shape:
            nf = n_free(n_units[i])
            shapes[r, :nf] = x[:nf]
            shapes[r, nf:] = np.nan


@batch_kernel
def solve_rows(
    unit_params,
    h,
    n_units,
    design_status,
    row_design,
    row_state,
    gtol,
    xtol,
    max_iter,
    max_step,
    want_stiffness,
    want_min_eig,
    out,
    status,
    found,
    n_iter,
    shapes,
):
    """Solve every (design, state) row in parallel.

    Parameters
    ----------
    unit_params : ndarray of shape (n_designs, MAX_UNITS, N_COLS)
    h : ndarray of shape (n_designs,), mm
    n_units : ndarray of int64, shape (n_designs,)
    design_status : ndarray of int8, shape (n_designs,)
        Rows of designs whose status is not ``OK`` are copied through with NaN outputs.
    row_design : ndarray of int64, shape (n_rows,)
        Design of each row.
    row_state : ndarray of int64, shape (n_rows,)
        Requested state of each row.
    gtol, xtol, max_iter, max_step
        Newton controls.
    want_stiffness, want_min_eig : bool
        Which optional outputs to compute.
    out : ndarray of shape (n_rows, N_OUT)
        Per-state outputs (columns ``OUT_*`` of :mod:`.states`).
    status : ndarray of int8, shape (n_rows,)
    found : ndarray of int64, shape (n_rows,)
    n_iter : ndarray of int32, shape (n_rows,)
    shapes : ndarray of shape (n_rows, 4·MAX_UNITS - 2) or (n_rows, 0)
        Free coordinates of each row's minimum (NaN-padded), or nothing.
    """
    n_rows = row_design.shape[0]
    n_blocks = (n_rows + BLOCK_ROWS - 1) // BLOCK_ROWS
    for b in prange(n_blocks):
        first = b * BLOCK_ROWS
        last = min(first + BLOCK_ROWS, n_rows)
        _solve_rows(
            unit_params,
            h,
            n_units,
            design_status,
            row_design,
            row_state,
            first,
            last,
            gtol,
            xtol,
            max_iter,
            max_step,
            want_stiffness,
            want_min_eig,
            out,
            status,
            found,
            n_iter,
            shapes,
        )


@kernel
def solve_rows_serial(
    unit_params,
    h,
    n_units,
    design_status,
    row_design,
    row_state,
    gtol,
    xtol,
    max_iter,
    max_step,
    want_stiffness,
    want_min_eig,
    out,
    status,
    found,
    n_iter,
    shapes,
):
    """:func:`solve_rows` on the calling thread, for small batches.

    Starting a parallel region wakes the worker threads, which costs from tens of microseconds on
    an idle machine to milliseconds on a loaded one: more than a few designs' solves. Same
    arguments and results as :func:`solve_rows`.
    """
    _solve_rows(
        unit_params,
        h,
        n_units,
        design_status,
        row_design,
        row_state,
        0,
        row_design.shape[0],
        gtol,
        xtol,
        max_iter,
        max_step,
        want_stiffness,
        want_min_eig,
        out,
        status,
        found,
        n_iter,
        shapes,
    )


@kernel
def solve_repeatedly(
    unit_params,
    h,
    requested,
    gtol,
    xtol,
    max_iter,
    max_step,
    want_stiffness,
    want_min_eig,
    repeats,
):
    """Solve one design-state ``repeats`` times (for timing single designs); returns the status.

    Workspace and outputs are allocated once, as in :func:`solve_rows`, so the time per repeat
    is the solver's own.
    """
    ws = workspace()
    x = np.empty(n_free(MAX_UNITS))
    out = np.empty(N_OUT)
    status = 0
    for _ in range(repeats):
        status, _, _ = solve_state(
            unit_params,
            h,
            requested,
            gtol,
            xtol,
            max_iter,
            max_step,
            want_stiffness,
            want_min_eig,
            x,
            out,
            ws,
        )
    return status


__all__ = ["N_OUT", "solve_repeatedly", "solve_rows", "solve_rows_serial"]
