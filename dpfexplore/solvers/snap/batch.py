"""Snap pressures of many designs at once: the rising ramp from flat, in parallel.

:func:`snap_pressures_batch` runs the walk of :func:`~.continuation.snap_pressures` (rising
ramp from the flat finger, then each visited state's release) for every design of a batch in
one Numba ``prange`` call, and returns columns for a sweep; :func:`inversion_pressures_batch`
keeps the first inversion pressure of every unit. The method, tolerances and landings are those
of :mod:`.continuation`.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics.motion import ETA_INTERNAL, ETA_ISO, MASS_PER_UNIT
from ..._kernels.records import LatticeBatch, Physics
from ..._kernels.snap import walk as ksnap
from ..._kernels.snap.records import BatchLanding, Ramp, SnapRows
from ...model import status as st
from ...model.design import DesignBatch
from ...model.domain import MAX_UNITS
from ..lattice import batch_constants, pack_batch
from .settings import DEFAULT_P_MAX, EVENT_CAPACITY, LANDING_MODELS
from .settings import check_kick as _kick
from .settings import check_pressure as _pressure
from .settings import landing_model as _model

__all__ = ["inversion_pressures_batch", "snap_pressures_batch"]


def snap_pressures_batch(
    batch: DesignBatch,
    *,
    P_max: float = DEFAULT_P_MAX,
    P_min: float = 0.0,
    release: bool = True,
    model: str = "rodas4",
    kick: float | None = None,
) -> dict[str, NDArray]:
    """The rising ramp from the flat finger of many designs, in parallel (Numba ``prange``).

    Parameters
    ----------
    batch : DesignBatch
        Invalid designs keep their status and get no events.
    P_max, P_min, release, model, kick
        As for :func:`snap_pressures` (``release`` walks down to ``P_min``).

    Returns
    -------
    dict of str to ndarray
        ``status`` (int8, (n,)); ``n_events`` (int64, (n,)); per event ``j`` (``(n, 48)``,
        padding NaN / -1): ``event_pressure`` (MPa), ``event_kind`` (int8: 1 snap, 2
        crossing, 3 unsettled), ``event_before``, ``event_after`` (state integers, unit 1 = most
        significant bit; -1 after an unsettled fold); per visited state ``j`` (0 = flat,
        ``j`` = after event ``j - 1``; ``(n, 49)``):
        ``release_status`` (int8), ``release_state`` (int64, -1 if none) and
        ``release_pressure`` (MPa: where the state is left on the way down; NaN: never);
        ``inversion_pressure`` ((n, 12), MPa: first pressure at which each unit is inverted;
        ``inf`` not by ``P_max``; NaN padding, invalid designs, or a walk that failed first);
        ``fitted_range`` (bool, (n,)); ``no_contact`` (bool, (n, 12): the unit's dome reach
        was clamped, see :attr:`SnapSequence.no_contact`).

    Notes
    -----
    Landings are certified stable by the kernels (symmetric-part Cholesky or eigenvalues of
    ``C⁻¹K``); the dense re-check of :func:`snap_pressures` (``verify``) is not repeated here.
    """
    if not isinstance(batch, DesignBatch):
        raise ValueError(f"batch = {batch!r}: must be a DesignBatch")
    P_max = _pressure("P_max", P_max)
    P_min = _pressure("P_min", P_min)
    if not P_min <= 0.0 < P_max:
        raise ValueError(f"P_min = {P_min}, P_max = {P_max}: need P_min <= 0 < P_max (MPa)")
    if model not in LANDING_MODELS:
        raise ValueError(f"model = {model!r}: choose one of {LANDING_MODELS}")
    kick = _kick(kick)
    n = len(batch)
    design_status = batch.status()
    valid = design_status == st.OK
    unit_params, h, n_units = pack_batch(batch)
    _, ctrl = _model(model, 1)
    status = design_status.astype(np.int64)
    n_events = np.zeros(n, dtype=np.int64)
    events = np.full((n, EVENT_CAPACITY, ksnap.N_EV), np.nan)
    rel_status = np.full((n, EVENT_CAPACITY + 1), st.NOT_COMPUTED, dtype=np.int64)
    rel_state = np.full((n, EVENT_CAPACITY + 1), -1, dtype=np.int64)
    rel_p = np.full((n, EVENT_CAPACITY + 1), np.nan)
    if n:
        # Rows differ in cost by 10x (number of snaps, slow landings): threads take rows one
        # at a time as they free up rather than a fixed share each.
        previous = numba.set_parallel_chunksize(1)
        try:
            mass = 0.0 if model == "rodas4-overdamped" else MASS_PER_UNIT
            ksnap.snap_batch(
                LatticeBatch(unit_params, h, n_units),
                valid,
                Ramp(P_max, P_min, bool(release)),
                BatchLanding(Physics(ETA_INTERNAL, ETA_ISO, mass), ctrl, float(kick)),
                SnapRows(status, n_events, events, rel_status, rel_state, rel_p),
            )
        finally:
            numba.set_parallel_chunksize(previous)
    slot = np.arange(EVENT_CAPACITY)[None, :] < n_events[:, None]
    kind = np.where(slot, np.nan_to_num(events[..., ksnap.EV_KIND], nan=-1), -1).astype(np.int8)
    before = np.where(slot, np.nan_to_num(events[..., ksnap.EV_BEFORE], nan=-1), -1)
    after = np.where(slot, np.nan_to_num(events[..., ksnap.EV_AFTER], nan=-1), -1)
    pressure = np.where(slot, events[..., ksnap.EV_P], np.nan)
    out = {
        "status": status.astype(np.int8),
        "n_events": n_events,
        "event_pressure": pressure,
        "event_kind": kind,
        "event_before": before.astype(np.int64),
        "event_after": after.astype(np.int64),
        "release_status": rel_status.astype(np.int8),
        "release_state": rel_state,
        "release_pressure": rel_p,
        "fitted_range": valid & batch.in_fitted_range(),
        "no_contact": np.asarray(batch_constants(batch, domes=False)["no_contact"], dtype=bool)
        & (np.arange(MAX_UNITS)[None, :] < n_units[:, None])
        & valid[:, None],
    }
    out["inversion_pressure"] = _inversion_from_events(out, n_units, valid)
    return out


def _inversion_from_events(out, n_units, valid) -> NDArray:
    """First pressure each unit is inverted at, from the rising walks' event columns."""
    n = n_units.shape[0]
    result = np.full((n, MAX_UNITS), np.nan)
    unit = np.arange(MAX_UNITS)[None, :]
    active = valid[:, None] & (unit < n_units[:, None])
    ok = out["status"] == st.OK
    result[active] = np.inf
    result[active & ~ok[:, None]] = np.nan
    shift = np.maximum(n_units[:, None] - 1 - unit, 0)
    for j in range(EVENT_CAPACITY):
        before = out["event_before"][:, j : j + 1]
        after = out["event_after"][:, j : j + 1]
        p = out["event_pressure"][:, j : j + 1]
        bit_after = (after >> shift) & 1
        bit_before = (before >> shift) & 1
        went = active & (before >= 0) & (after >= 0) & (bit_after == 1) & (bit_before == 0)
        first = went & ~np.isfinite(result)
        result = np.where(first, p, result)
    return result


def inversion_pressures_batch(
    batch: DesignBatch, *, P_max: float = DEFAULT_P_MAX, model: str = "rodas4"
) -> NDArray[np.float64]:
    """First inversion pressure (MPa) of every unit of many designs, shape ``(n, 12)``.

    See :func:`snap_pressures_batch` (its ``inversion_pressure``; no release walks).
    """
    return snap_pressures_batch(batch, P_max=P_max, release=False, model=model)[
        "inversion_pressure"
    ]
