"""Kernel tables of designs: status codes, per-unit tables and their derivative tables.

:func:`design_tables` turns the raw design arrays of a batch (those of
:class:`dpfexplore.model.design.DesignBatch`) into what the state kernels read: each design's
status code, its per-unit table (columns of :mod:`.layout`) and segment height, and on request the
derivatives of the table's constants in the design parameters (for the sensitivities,
:mod:`.sensitivity.states`). ``k_b``, ``alpha`` and the reach come from the batch's constants set,
read as the array of :meth:`dpfexplore.model.constants_set.ConstantsSet.kernel_forms` and evaluated
by the same arithmetic as its NumPy methods (bit-identical); the beam constants (``k_lim``,
``k_t``) are those of :mod:`dpfexplore.model.constants`, compiled inline from the same source.

The status codes are those of :meth:`DesignBatch.status` (``OK``, ``INVALID_INPUT``,
``INVALID_CONSTANTS``), by the rules of :func:`dpfexplore.model.validation.status_code` compiled
inline; only the one-line descriptions of the problems stay with the NumPy validation of the
model layer. The domes' constants are evaluated a block of designs at a time, then each design's
rows filled. This makes a batch's validation and packing one compiled pass, well under a
microsecond per design, where the NumPy path costs a few hundred microseconds of call overhead
for any batch size.
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from ...model.closed_form import FORM_ALPHA, FORM_K_HAT, FORM_TIP_RATIO, N_FORMS
from ...model.constants import (
    ALPHA_BISTABLE,
    NO_CONTACT_REACH,
    POST_STIFFNESS_FACTOR,
    U_INVERSION_WITHOUT_BARRIER,
)
from ...model.domain import MAX_UNITS
from ...model.quantities import SET_FORMS
from .._jit import kernel
from ..layout import (
    COL_D,
    COL_KLIM,
    COL_KPOST,
    COL_KT,
    COL_P,
    COL_PEN,
    COL_U_HELD,
    COL_U_HI,
    COL_U_INV,
    COL_U_LO,
    N_COLS,
    PHYSICAL_COLUMNS,
)
from ..records import DesignArrays, SharedParams, TableOutputs
from .model_forms import (
    constant_derivatives_form,
    constants_status,
    geometry_status,
    k_lim_form,
    k_t_form,
    segment_height_form,
)
from .set_forms import block_size, dome_block, set_constants_block, set_terms

#: Rows of the derivative table: the kernel table's physical columns ``COL_P..COL_KT`` (same
#: indices, :data:`.layout.PHYSICAL_COLUMNS`), then the segment height ``h``.
DC_H = len(PHYSICAL_COLUMNS)
N_DCONST = DC_H + 1
#: Kernel-table column of each closed form of a constants set (rows ``FORM_*``) whose quantity
#: the table holds as it is (-1: a column computed from it, as the reach from ``tip_dis``).
FORM_COLUMNS = tuple(
    -1 if form.column is None else PHYSICAL_COLUMNS.index(form.column) for form in SET_FORMS
)
#: Columns of the derivative table: the unit's own ``H``, ``U_L``, ``U_sep``, then the shared
#: ``t`` and ``t_lim``.
DP_H = 0
DP_UL = 1
DP_USEP = 2
DP_T = 3
DP_TLIM = 4
N_DPARAM = 5


@kernel
def _unit_row(H, U_L, U_sep, shared, alpha, tip, row):
    """Fill one unit's kernel table row; returns True where ``d`` was clamped (no contact).

    ``H``, ``U_L``, ``U_sep``: the unit's (mm); ``shared``: the design's
    :class:`~.records.SharedParams`; ``alpha``, ``tip`` (``tip_dis``, mm): the dome's constants
    under the batch's set. The columns of the set's quantities that the table holds as they
    are (:data:`FORM_COLUMNS`: ``k_b``, ``alpha``) are the caller's (:func:`fill_designs`).
    """
    t, t_lim, E, nu, r_b, t_ch = shared
    # the reach of MODEL.md §3, in ConstantsSet.reach's order of operations
    raw = tip - H - U_sep - t_ch / 2.0 - t / 2.0
    no_contact = raw <= 0.0
    k_lim = k_lim_form(E, t_lim, r_b, U_L, t, t_ch)
    row[COL_P] = U_L + t_ch + U_sep
    row[COL_D] = NO_CONTACT_REACH if no_contact else raw
    row[COL_KLIM] = k_lim
    row[COL_KPOST] = POST_STIFFNESS_FACTOR * k_lim
    row[COL_KT] = k_t_form(E, t_lim, nu, r_b, U_sep, t, t_ch)
    row[COL_U_LO] = -np.inf
    row[COL_U_HI] = np.inf
    row[COL_PEN] = 0.0
    # dome_extrema / inversion_threshold of model.constants: barrier and second minimum where
    # the isolated dome is bistable, else 3/4 and the reach.
    u_inv = U_INVERSION_WITHOUT_BARRIER
    u_held = 1.0
    if alpha < ALPHA_BISTABLE:
        root = math.sqrt((1.0 - 9.0 * alpha) / (1.0 - alpha))
        u_barrier = (3.0 - root) / 4.0
        u_second = (3.0 + root) / 4.0
        if u_barrier == u_barrier:
            u_inv = u_barrier
        if u_second == u_second:
            u_held = u_second
    row[COL_U_INV] = u_inv
    row[COL_U_HELD] = u_held
    return no_contact


@kernel
def _derivative_rows(H, U_L, U_sep, shared, partials, contact, dtab):
    """Fill one unit's derivative table ``(N_DCONST, N_DPARAM)`` (MODEL.md §3 chain rule).

    The constants set's quantities through their own derivatives in ``H`` and ``t``,
    ``partials`` (the unit's column of :attr:`~.set_forms.DomeBlock.partials`,
    rows ``2 FORM_*`` and ``2 FORM_* + 1``), into the rows of their columns
    (:data:`FORM_COLUMNS`), and the reach through those of ``tip_dis``; ``contact`` is 0 where
    the reach is clamped (a constant there, so its derivatives vanish). Other arguments as
    :func:`_unit_row`.
    """
    dd_dH = (partials[2 * FORM_TIP_RATIO] - 1.0) * contact
    dd_dt = (partials[2 * FORM_TIP_RATIO + 1] - 0.5) * contact
    dd_dUsep = -1.0 * contact
    (
        _,
        _,
        _,
        _,
        _,
        _,
        _,
        _,
        dklim_dUL,
        dklim_dt,
        dklim_dtlim,
        dkt_dUsep,
        dkt_dt,
        dkt_dtlim,
    ) = constant_derivatives_form(H, U_L, U_sep, shared)
    for c in range(N_DCONST):
        for j in range(N_DPARAM):
            dtab[c, j] = 0.0
    for f in range(N_FORMS):
        if FORM_COLUMNS[f] >= 0:
            dtab[FORM_COLUMNS[f], DP_H] = partials[2 * f]
            dtab[FORM_COLUMNS[f], DP_T] = partials[2 * f + 1]
    dtab[COL_P, DP_UL] = 1.0
    dtab[COL_P, DP_USEP] = 1.0
    dtab[COL_D, DP_H] = dd_dH
    dtab[COL_D, DP_USEP] = dd_dUsep
    dtab[COL_D, DP_T] = dd_dt
    dtab[COL_KLIM, DP_UL] = dklim_dUL
    dtab[COL_KLIM, DP_T] = dklim_dt
    dtab[COL_KLIM, DP_TLIM] = dklim_dtlim
    dtab[COL_KPOST, DP_UL] = POST_STIFFNESS_FACTOR * dklim_dUL
    dtab[COL_KPOST, DP_T] = POST_STIFFNESS_FACTOR * dklim_dt
    dtab[COL_KPOST, DP_TLIM] = POST_STIFFNESS_FACTOR * dklim_dtlim
    dtab[COL_KT, DP_USEP] = dkt_dUsep
    dtab[COL_KT, DP_T] = dkt_dt
    dtab[COL_KT, DP_TLIM] = dkt_dtlim
    # h = UC/2 + t_lim + t (constants.segment_height)
    dtab[DC_H, DP_T] = 1.0
    dtab[DC_H, DP_TLIM] = 1.0


@kernel(inline="always")
def batch_block_size(designs):
    """The dome block a batch's table build uses: all its domes, up to ``DOME_BLOCK``."""
    total = 0
    for i in range(designs.n_units.shape[0]):
        total += min(max(designs.n_units[i], 0), MAX_UNITS)
    return block_size(total, MAX_UNITS)


@kernel(inline="always")
def gather_domes(designs, first, block):
    """Put the units of designs ``first, first + 1, ...`` into ``block`` while they fit.

    Returns ``(end, count)``: the designs ``first .. end - 1`` are in, with ``count`` domes.
    """
    n_units, H, t, E, r_b = designs.n_units, designs.H, designs.t, designs.E, designs.r_b
    count = 0
    end = first
    while end < n_units.shape[0]:
        active = min(max(n_units[end], 0), MAX_UNITS)
        if count + active > block.H.shape[0]:
            break
        for k in range(active):
            block.H[count] = H[end, k]
            block.t[count] = t[end]
            block.r_b[count] = r_b[end]
            block.E[count] = E[end]
            count += 1
        end += 1
    return end, count


@kernel(inline="always")
def fill_designs(designs, first, end, block, out):
    """Status and tables of designs ``first .. end - 1`` from their domes' constants in ``block``.

    ``block.values`` holds the set's quantities (``k_b``, ``alpha``, ``tip_dis``, ...) of the
    designs' units in order (those :func:`gather_domes` put in), ``block.partials`` their
    derivatives when ``out`` asks for the derivative tables. Arguments as :func:`design_tables`.
    """
    n_units, H, U_L, U_sep, t, t_lim, E, nu, r_b, t_ch = designs
    status, table, h, no_contact, dtab = out
    want_derivatives = dtab.shape[0] > 0
    values = block.values
    dome = 0
    for i in range(first, end):
        # the status of validation.status_code: geometry first, then the constants, checked on
        # the rows computed below (each closed form evaluated once)
        shared = SharedParams(t[i], t_lim[i], E[i], nu[i], r_b[i], t_ch[i])
        status[i] = geometry_status(n_units[i], H[i], U_L[i], U_sep[i], shared)
        h[i] = segment_height_form(r_b[i], t_lim[i], t[i])
        active = min(max(n_units[i], 0), MAX_UNITS)
        for k in range(MAX_UNITS):
            if k >= active:
                table[i, k, :] = np.nan
                no_contact[i, k] = False
                if want_derivatives:
                    dtab[i, k] = np.nan
                continue
            row = table[i, k]
            for f in range(N_FORMS):  # the set's quantities the table holds as they are
                if FORM_COLUMNS[f] >= 0:
                    row[FORM_COLUMNS[f]] = values[f, dome]
            alpha = values[FORM_ALPHA, dome]
            tip = values[FORM_TIP_RATIO, dome]
            clamped = _unit_row(H[i, k], U_L[i, k], U_sep[i, k], shared, alpha, tip, row)
            no_contact[i, k] = clamped
            if status[i] == st.OK:
                status[i] = constants_status(values[FORM_K_HAT, dome], alpha)
            if want_derivatives:
                _derivative_rows(
                    H[i, k],
                    U_L[i, k],
                    U_sep[i, k],
                    shared,
                    block.partials[:, dome],
                    0.0 if clamped else 1.0,
                    dtab[i, k],
                )
            dome += 1


@kernel
def design_tables(designs, forms, out):
    """Status, kernel table and (on request) derivative table of every design of a batch.

    The domes' constants are evaluated a block of designs at a time
    (:func:`~.set_forms.set_constants_block`), then each design's rows filled.

    ``designs`` and ``out`` are plain tuples of their records' fields, in order (:mod:`.records`;
    package docstring, "Records at the entry points").

    Parameters
    ----------
    designs : DesignArrays fields
        The arrays of a :class:`DesignBatch`.
    forms : tuple of (ndarray of int64, shape (N_FORMS, n_terms, 2); ndarray, (N_FORMS, n_terms))
        The batch's constants set: powers and coefficients of its closed forms
        (:meth:`~dpfexplore.model.constants_set.ConstantsSet.kernel_forms`).
    out : TableOutputs fields
        Receives each design's ``status`` code; the per-unit tables ``table`` (n, MAX_UNITS,
        N_COLS), whose rows past a design's ``N`` are NaN, filled for invalid designs too
        (meaningless there), as :func:`dpfexplore.solvers.lattice.pack_batch` did; the segment
        heights ``h`` (mm); ``no_contact``, True where the unit's ``d`` is clamped; and
        ``dtab`` (n, MAX_UNITS, N_DCONST, N_DPARAM), ``∂(constant)/∂(parameter)`` per unit
        (rows :data:`DC_H` and ``COL_P..COL_KT``, columns ``DP_*``), skipped when empty.
    """
    arrays, written = DesignArrays(*designs), TableOutputs(*out)
    terms = set_terms(forms, written.dtab.shape[0] > 0)
    block = dome_block(terms, batch_block_size(arrays))
    first = np.int64(0)  # not the literal 0: one compiled signature of the block functions
    while first < arrays.n_units.shape[0]:
        end, count = gather_domes(arrays, first, block)
        set_constants_block(terms, block, count)
        fill_designs(arrays, first, end, block, written)
        first = end


def empty_derivative_table():
    """The ``dtab`` argument of :func:`design_tables` that skips the derivatives."""
    return np.empty((0, 0, 0, 0))


__all__ = [
    "DC_H",
    "DP_H",
    "DP_T",
    "DP_TLIM",
    "DP_UL",
    "DP_USEP",
    "N_COLS",
    "N_DCONST",
    "N_DPARAM",
    "batch_block_size",
    "design_tables",
    "empty_derivative_table",
    "fill_designs",
    "gather_domes",
]
