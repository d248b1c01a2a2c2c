"""Batch entry points for states with their design sensitivities (:mod:`.sensitivity.states`).

Each block of rows is solved by the batch solver's own row routine
(:func:`.statics.batch._solve_rows`, so states and outputs are those of
:func:`.statics.batch.solve_rows` exactly), then the sensitivities of every row that reached a
minimum (``OK``, or ``COLLAPSED``: they describe the state found) are filled from its shape. Columns
are laid out with ``MAX_UNITS`` columns per per-unit parameter kind
(:func:`.sensitivity.states.parameter_column`), NaN past a design's ``N`` and on rows without a
minimum or without a positive definite Hessian there.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ...model import status as st
from ...model.domain import MAX_UNITS
from .._jit import batch_kernel, kernel
from ..layout import n_free
from ..records import DesignDerivatives, Lattice, SensitivityRows
from ..statics.batch import BLOCK_ROWS, _solve_rows, name_row_records
from .states import N_SENS, design_sensitivities, n_parameters, workspace


@kernel
def _sensitivity_rows(designs, rows, first, last, controls, outputs, derivatives, sens_rows):
    """Rows ``first`` to ``last - 1`` (arguments as :func:`solve_rows_sensitivities`)."""
    _solve_rows(designs, rows, first, last, controls, outputs)
    ws = workspace()
    unit_params, h, n_units, _ = designs
    status = outputs.status
    shapes = outputs.shapes
    dtab, E = derivatives
    sens, dxs = sens_rows
    keep_dx = dxs.shape[0] > 0
    no_dx = np.empty((0, 0))
    for r in range(first, last):
        if status[r] != st.OK and status[r] != st.COLLAPSED:
            sens[r] = np.nan
            if keep_dx:
                dxs[r] = np.nan
            continue
        i = rows.design[r]
        m = n_units[i]
        dx_r = dxs[r] if keep_dx else no_dx
        design_sensitivities(
            shapes[r, : n_free(m)],
            Lattice(unit_params[i, :m], h[i]),
            DesignDerivatives(dtab[i, :m], E[i]),
            MAX_UNITS,
            SensitivityRows(sens[r], dx_r),
            ws,
        )


@batch_kernel
def _sensitivity_rows_parallel(designs, rows, controls, outputs, derivatives, sens_rows):
    """Every row, blocks of rows in parallel (records named by the entry point)."""
    n_rows = rows.design.shape[0]
    n_blocks = (n_rows + BLOCK_ROWS - 1) // BLOCK_ROWS
    for b in prange(n_blocks):
        first = b * BLOCK_ROWS
        last = min(first + BLOCK_ROWS, n_rows)
        _sensitivity_rows(designs, rows, first, last, controls, outputs, derivatives, sens_rows)


@kernel
def solve_rows_sensitivities(designs, rows, controls, outputs, derivatives, sens_rows):
    """:func:`.statics.batch.solve_rows` plus the sensitivities of every row, in parallel.

    Each argument is a plain tuple of its record's fields, in order (:mod:`.records`), named
    here as :func:`.statics.batch.solve_rows` does.

    Parameters
    ----------
    designs, rows, controls, outputs
        As in :func:`.statics.batch.solve_rows`; ``outputs``' shapes, of shape (n_rows,
        4·MAX_UNITS - 2), receive the free coordinates of each row (needed here, so never
        empty).
    derivatives : DesignDerivatives fields
        Derivative tables (:func:`.tables.design_tables.design_tables`) and Young's moduli of the
        designs.
    sens_rows : SensitivityRows fields
        Receive the sensitivities (rows ``SENS_*`` of :mod:`.sensitivity.states`) and, when not
        empty, ``dx*/dθ`` of every row.
    """
    table, plan, newton, written = name_row_records(designs, rows, controls, outputs)
    partials, into = DesignDerivatives(*derivatives), SensitivityRows(*sens_rows)
    _sensitivity_rows_parallel(table, plan, newton, written, partials, into)


@kernel
def solve_rows_sensitivities_serial(designs, rows, controls, outputs, derivatives, sens_rows):
    """:func:`solve_rows_sensitivities` on the calling thread (small batches)."""
    table, plan, newton, written = name_row_records(designs, rows, controls, outputs)
    partials, into = DesignDerivatives(*derivatives), SensitivityRows(*sens_rows)
    n_rows = plan.design.shape[0]
    _sensitivity_rows(table, plan, np.int64(0), n_rows, newton, written, partials, into)


@kernel
def sensitivities_repeatedly(x, unit_params, h, dtab, E, repeats):
    """Sensitivities of one minimum ``repeats`` times (timing); returns whether they exist."""
    ws = workspace()
    n_units = unit_params.shape[0]
    sens = np.empty((N_SENS, n_parameters(n_units)))
    no_dx = np.empty((0, 0))
    ok = False
    for _ in range(repeats):
        ok = design_sensitivities(
            x,
            Lattice(unit_params, h),
            DesignDerivatives(dtab, E),
            n_units,
            SensitivityRows(sens, no_dx),
            ws,
        )
    return ok


__all__ = [
    "sensitivities_repeatedly",
    "solve_rows_sensitivities",
    "solve_rows_sensitivities_serial",
]
