"""Which rows a batch solve runs: one (design, requested state) pair per row.

:func:`row_plan` turns a state set (all inverted, the ``N + 1`` sequential states, all ``2^N``)
or one given state per design into the rows the state kernels solve; an invalid design keeps one
row with state -1. :func:`sequential_state_table` orders each design's units for sequential
activation (:mod:`.statics` module docstring).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .._kernels.layout import COL_ALPHA, COL_D, COL_KB
from ..model import status as st
from ..model.constants import analyse_domes
from ..model.design import DesignBatch
from ..model.domain import MAX_UNITS
from .lattice import KernelTables, batch_constants

__all__ = ["StateSet", "row_plan", "sequential_state_table"]

StateSet = Literal["all_inverted", "sequential", "all"]


def sequential_state_table(batch: DesignBatch, tables: KernelTables | None = None) -> NDArray:
    """Sequential states of every design, ``(n, MAX_UNITS + 1)``; row i's first N+1 are valid.

    The isolated domes' regimes and peak forces come from ``k_b``, ``alpha`` and ``d`` of the
    batch's kernel ``tables`` when given (the numbers of the set's NumPy forms, bit for bit: a
    single design's plan then costs no closed-form evaluation in NumPy), else from the set.
    """
    if tables is None:
        domes = batch_constants(batch)["domes"]
    else:
        table = tables.unit_params
        with np.errstate(all="ignore"):  # NaN padding, and invalid designs' meaningless rows
            domes = analyse_domes(table[:, :, COL_KB], table[:, :, COL_ALPHA], table[:, :, COL_D])
    n_units = np.clip(batch.n_units, 0, MAX_UNITS)[:, None]
    unit = np.arange(MAX_UNITS)[None, :]
    # Bistable domes by rising snap force, then the others (they cannot stay inverted on their
    # own), then padding; ties toward the base (lexsort is stable).
    group = np.where(unit >= n_units, 2, np.where(domes.regime == "bistable", 0, 1))
    peak = np.nan_to_num(domes.peak_force, nan=-np.inf)
    order = np.lexsort((peak, group), axis=-1)
    bits = np.where(order < n_units, 1 << np.maximum(n_units - 1 - order, 0), 0)
    return np.concatenate([np.zeros((len(batch), 1), np.int64), np.cumsum(bits, axis=1)], axis=1)


def row_plan(batch: DesignBatch, states: StateSet | Sequence[int], tables: KernelTables):
    """Rows (design index, requested state) for a state set; invalid designs get one row (-1).

    Parameters
    ----------
    batch : DesignBatch
    states : {"all_inverted", "sequential", "all"} or sequence of int
        As :func:`~dpfexplore.solvers.statics.solve_batch` takes them.
    tables : KernelTables
        The batch's kernel tables (status codes; ``k_b``, ``alpha``, ``d`` for the sequential
        order).

    Returns
    -------
    row_design, row_state : ndarray of int64
    """
    n_designs = len(batch)
    if isinstance(states, str) and states not in ("all_inverted", "sequential", "all"):
        raise ValueError(f"states = {states!r}: choose 'all_inverted', 'sequential' or 'all'")
    if n_designs == 1 and (not isinstance(states, str) or states == "all_inverted"):
        return _single_design_row(states, int(batch.n_units[0]), tables.status[0] == st.OK)
    valid = tables.status == st.OK
    if not isinstance(states, str):
        return _given_states(states, n_designs, batch.n_units, valid)
    n_units = np.where(valid, batch.n_units, 0)
    if states == "all_inverted":
        requested = np.left_shift(1, n_units) - 1
        requested[~valid] = -1
        return np.arange(n_designs, dtype=np.int64), requested
    counts = np.where(valid, 2**n_units if states == "all" else n_units + 1, 1)
    row_design = np.repeat(np.arange(n_designs, dtype=np.int64), counts)
    position = np.arange(row_design.size) - np.repeat(np.cumsum(counts) - counts, counts)
    if states == "all":
        requested = position
    else:
        requested = sequential_state_table(batch, tables)[row_design, position]
    return row_design, np.where(valid[row_design], requested, -1).astype(np.int64)


def _single_design_row(states: str | Sequence[int], n_units: int, valid: bool):
    """The one row of a single design: all inverted, or its one given state (-1 if invalid).

    In scalars: a NumPy call costs about a microsecond, which a single design's solve (the
    optimisers' and lookup's polish calls, 20-100 µs) notices; the checks are those of
    :func:`_given_states`.
    """
    if isinstance(states, str):  # "all_inverted"; an invalid design's N may be anything
        requested = (1 << n_units) - 1 if valid else -1
    else:
        given = np.asarray(states)
        if given.shape != (1,) or not np.issubdtype(given.dtype, np.integer):
            return _given_states(states, 1, np.array([n_units]), np.array([valid]))
        requested = int(given[0])
        if valid and (requested < 0 or requested >> n_units):
            raise ValueError("states: a requested state does not fit its design's units")
    return np.zeros(1, dtype=np.int64), np.array([requested if valid else -1], dtype=np.int64)


def _given_states(states: Sequence[int], n_designs: int, n_units: NDArray, valid: NDArray):
    """Rows of one given state per design (invalid designs: -1).

    Few NumPy calls: single designs and small batches are what optimisers send, and each call
    costs about a microsecond.
    """
    requested = np.array(states, dtype=np.int64)
    if requested.shape != (n_designs,):
        raise ValueError(
            f"states: need one requested state per design, got shape {requested.shape}"
        )
    # negative, or a bit beyond the design's units (invalid designs shift by 0 and are masked)
    if (valid & ((requested >> np.where(valid, n_units, 0)) != 0)).any():
        raise ValueError("states: a requested state does not fit its design's units")
    requested[~valid] = -1
    return np.arange(n_designs, dtype=np.int64), requested
