"""What the dynamics front ends share: methods, controls, results and the batch runner.

:func:`dpfexplore.solvers.dynamics.simulate.simulate` and ``reset_times_batch``, the SciPy baseline
(:mod:`dpfexplore.solvers.dynamics.scipy_baseline`) and the release model
(:mod:`dpfexplore.solvers.dynamics.release`) all build on these pieces; keeping them here lets each
of those modules import downward only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics import events as kev
from ..._kernels.dynamics.batch import (
    CLASS_BISTABLE,
    CLASS_METASTABLE,
    CLASS_MONOSTABLE,
    CLASS_NEVER_INVERTED,
    CLASS_NO_CONTACT,
    summarise_units,
)
from ..._kernels.lattice import dome_extensions, unpack_nodes
from ...model import status as st
from ...model.design import Design, DesignBatch
from ...model.domain import MAX_UNITS
from ...model.pressure import PressureProfile
from ..lattice import pack_batch
from .methods import DEFAULT_METHOD, METHODS, MethodInfo

__all__ = [
    "CLASS_NAMES",
    "DEFAULT_METHOD",
    "METHODS",
    "MethodInfo",
    "SimulationResult",
    "build_result",
    "check_horizon",
    "controls",
    "empty_reset_columns",
    "mark_no_contact",
    "method_info",
    "positive_number",
    "run_reset_batch",
]

#: Unit class codes (``reset_times_batch()["unit_class"]``) and their names. ``no_contact``: the
#: unit's reach ``d`` is clamped (MODEL.md §3), so it has no inversion and no reset time.
CLASS_NAMES: dict[int, str | None] = {
    CLASS_NEVER_INVERTED: None,
    CLASS_BISTABLE: "bistable",
    CLASS_METASTABLE: "metastable",
    CLASS_MONOSTABLE: "monostable",
    CLASS_NO_CONTACT: "no_contact",
}


def method_info(name: str) -> MethodInfo:
    """The :class:`MethodInfo` of ``name``; ``ValueError`` listing the choices if unknown."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(
            f"method = {name!r}: unknown; choose one of {', '.join(sorted(METHODS))}"
        ) from None


@dataclass(frozen=True)
class SimulationResult:
    """One simulated scene.

    Attributes
    ----------
    design : Design
    profile : PressureProfile
    method : str
    status : Status
    t : ndarray of shape (m,), s
        Sample times (evenly spaced from 0 to ``t_end``).
    x : ndarray of shape (m, 4N - 2), mm
        Free coordinates at the samples (NaN past an early stop).
    tip : ndarray of shape (m, 2), mm
        Tip node ``L_N``.
    extensions : ndarray of shape (m, N)
        Dome extensions over their reach, ``u = x̄/d``.
    pressure : ndarray of shape (m,), MPa
    snap_through, snap_back : ndarray of shape (N,), s
        First upward and last downward threshold crossing (NaN if none).
    reset_time : ndarray of shape (N,), s
        After ``profile.t_release``; ``inf`` if still inverted at ``t_end``; NaN if never
        inverted or no contact.
    unit_class : tuple of (str or None)
        ``"bistable"``, ``"metastable"``, ``"monostable"``, ``"no_contact"`` (reach ``d``
        clamped: no inversion in this model; its times are NaN and its final-state bit 0) or
        None (never inverted).
    final_state : str
        Inversion bits at the end, unit 1 first (e.g. ``"111100"``).
    events : ndarray of shape (n_events, 3)
        Every threshold crossing, no-contact units' included: time (s), unit (1-based),
        direction (+1 snap-through, -1 snap-back).
    final_x, final_v : ndarray of shape (4N - 2,)
        State at the end of the run (mm, mm/s).
    t_end : float, s
        Requested end of the run; ``horizon = t_end - t_release``.
    stats : dict
        Steps, rejected steps, right-hand-side evaluations, factorisations, early stop.
    """

    design: Design
    profile: PressureProfile
    method: str
    status: st.Status
    t: NDArray[np.float64]
    x: NDArray[np.float64]
    tip: NDArray[np.float64]
    extensions: NDArray[np.float64]
    pressure: NDArray[np.float64]
    snap_through: NDArray[np.float64]
    snap_back: NDArray[np.float64]
    reset_time: NDArray[np.float64]
    unit_class: tuple[str | None, ...]
    final_state: str
    events: NDArray[np.float64]
    final_x: NDArray[np.float64]
    final_v: NDArray[np.float64]
    t_end: float
    stats: dict[str, int] = field(default_factory=dict)

    @property
    def horizon(self) -> float:
        """Time simulated after the end of the profile, s (the bound on an ``inf`` reset)."""
        return self.t_end - self.profile.t_release

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``null`` for never inverted, ``"inf"`` for never reset)."""

        def times(values, *, inf_text: bool) -> list:
            out = []
            for v in values:
                if math.isnan(v):
                    out.append(None)
                elif math.isinf(v):
                    out.append("inf" if inf_text else None)
                else:
                    out.append(round(float(v), 9))
            return out

        return {
            "final_state": self.final_state,
            "reset_times": times(self.reset_time, inf_text=True),
            "snap_through": times(self.snap_through, inf_text=False),
            "snap_back": times(self.snap_back, inf_text=False),
            "classes": list(self.unit_class),
            "status": self.status.label,
            "method": self.method,
            "horizon": self.horizon,
            "t_release": self.profile.t_release,
            "stats": dict(self.stats),
        }


def controls(
    info: MethodInfo, *, t_release: float, atol, rtol, h_max, max_steps, stop_when_reset: bool
) -> NDArray[np.float64]:
    """Integrator control vector (``kev.CTRL_*``) from a method's defaults and overrides."""
    ctrl = np.zeros(kev.N_CTRL)
    ctrl[kev.CTRL_RTOL] = 0.0 if rtol is None else positive_number("rtol", rtol, allow_zero=True)
    ctrl[kev.CTRL_ATOL] = info.atol if atol is None else positive_number("atol", atol)
    ctrl[kev.CTRL_H_MAX] = info.h_max if h_max is None else positive_number("h_max", h_max)
    ctrl[kev.CTRL_MAX_STEPS] = (
        info.max_steps if max_steps is None else positive_number("max_steps", max_steps)
    )
    ctrl[kev.CTRL_TAU_END] = t_release
    ctrl[kev.CTRL_STOP_WHEN_RESET] = 1.0 if stop_when_reset else 0.0
    ctrl[kev.CTRL_H_MIN] = 1e-14
    if ctrl[kev.CTRL_ATOL] == 0.0 and ctrl[kev.CTRL_RTOL] == 0.0:
        raise ValueError("atol = 0 and rtol = 0: one tolerance must be positive")
    return ctrl


def positive_number(name: str, value, *, allow_zero: bool = False) -> float:
    """``value`` as a float; ``ValueError`` naming ``name`` unless finite and > 0 (or >= 0)."""
    value = float(value)
    if not math.isfinite(value) or value < 0.0 or (value == 0.0 and not allow_zero):
        raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
    return value


def check_horizon(t_end: float, profile: PressureProfile) -> float:
    """``t_end`` as a float; ``ValueError`` unless finite, > 0 and not before the profile ends."""
    t_end = float(t_end)
    if not math.isfinite(t_end) or t_end <= 0.0:
        raise ValueError(f"t_end = {t_end!r}: must be a finite time > 0 s")
    if t_end < profile.t_release:
        raise ValueError(
            f"t_end = {t_end} s: must not end before the pressure profile ({profile.t_release} s);"
            " reset times are measured from the end of the profile"
        )
    return t_end


def build_result(
    design, profile, method, status, params, t_out, x_out, rec, log, stats, final_x, final_v, t_end
) -> SimulationResult:
    """Assemble a :class:`SimulationResult` from a run's arrays."""
    n_units = design.n_units
    reset = np.empty(n_units)
    snap_through = np.empty(n_units)
    snap_back = np.empty(n_units)
    classes = np.empty(n_units, dtype=np.int64)
    state = summarise_units(
        rec, profile.t_release, int(status), reset, snap_through, snap_back, classes
    )
    no_contact = design.constants.springs(
        np.asarray(design.H), design.t, design.r_b, design.E, np.asarray(design.U_sep), design.t_ch
    )["no_contact"]
    states = np.array([state], dtype=np.int64)
    mark_no_contact(
        no_contact[None],
        np.array([n_units]),
        states,
        reset[None],
        snap_through[None],
        snap_back[None],
        classes[None],
    )
    state = int(states[0])
    tip, ext = _tip_and_extensions(params, x_out)
    n_events = int(min(stats[kev.STAT_EVENTS], log.shape[0]))
    events = log[:n_events].copy()
    events[:, 1] += 1.0
    return SimulationResult(
        design=design,
        profile=profile,
        method=method,
        status=status,
        t=t_out,
        x=x_out,
        tip=tip,
        extensions=ext,
        pressure=profile(t_out),
        snap_through=snap_through,
        snap_back=snap_back,
        reset_time=reset,
        unit_class=tuple(CLASS_NAMES[int(c)] for c in classes),
        final_state=format(state, f"0{n_units}b"),
        events=events,
        final_x=final_x,
        final_v=final_v,
        t_end=t_end,
        stats={
            "steps": int(stats[kev.STAT_STEPS]),
            "rejected": int(stats[kev.STAT_REJECTED]),
            "rhs_evaluations": int(stats[kev.STAT_RHS]),
            "factorisations": int(stats[kev.STAT_FACTOR]),
            "crossings": int(stats[kev.STAT_EVENTS]),
            "stopped_early": int(stats[kev.STAT_STOPPED_EARLY]),
        },
    )


def _tip_and_extensions(params, x_out: NDArray) -> tuple[NDArray, NDArray]:
    n_units = params.n_units
    m = x_out.shape[0]
    tip = np.full((m, 2), np.nan)
    ext = np.full((m, n_units), np.nan)
    pos = np.empty((2 * n_units + 2, 2))
    for j in range(m):
        if not np.isfinite(x_out[j, 0]):
            continue
        unpack_nodes(x_out[j], params.unit_params, params.h, pos)
        tip[j] = pos[2 * n_units + 1]
        dome_extensions(x_out[j], params.unit_params, params.h, pos, ext[j])
    return tip, ext


def mark_no_contact(
    no_contact, n_units, final_state, reset, snap_through, snap_back, unit_class
) -> None:
    """Class the no-contact units of simulated designs, in place.

    A unit whose reach ``d`` was clamped (MODEL.md §3) crosses its threshold a few µm from
    flat, so its "inversion" and "reset" mean nothing: its class becomes ``CLASS_NO_CONTACT``
    (a property of the design, whatever the run's status), its reset and snap times NaN and its
    bit of the final state 0.

    Parameters
    ----------
    no_contact : ndarray of bool, shape (n, k)
        Per design and unit; False on padding and on rows that were not simulated.
    n_units : ndarray of int, shape (n,)
    final_state : ndarray of int64, shape (n,)
        Unit 1 = most significant of ``n_units`` bits; entries < 0 (no state) are left alone.
    reset, snap_through, snap_back : ndarray of shape (n, >= k), s
    unit_class : ndarray of int, shape (n, >= k)
    """
    rows, units = np.nonzero(no_contact)
    for i, k in zip(rows, units, strict=True):
        reset[i, k] = snap_through[i, k] = snap_back[i, k] = np.nan
        unit_class[i, k] = CLASS_NO_CONTACT
        if final_state[i] >= 0:
            final_state[i] &= ~(1 << int(n_units[i] - 1 - k))


def empty_reset_columns(batch: DesignBatch) -> dict[str, NDArray]:
    """The arrays of the :func:`reset_times_batch` contract before any simulation.

    ``status`` is each design's input status; every output is NaN, -1 or "never inverted".
    """
    n = len(batch)
    return {
        "status": batch.status().astype(np.int8),
        "final_state": np.full(n, -1, dtype=np.int64),
        "reset_time": np.full((n, MAX_UNITS), np.nan),
        "snap_through": np.full((n, MAX_UNITS), np.nan),
        "snap_back": np.full((n, MAX_UNITS), np.nan),
        "unit_class": np.full((n, MAX_UNITS), CLASS_NEVER_INVERTED, dtype=np.int8),
    }


def run_reset_batch(batch, profile, info, atol, max_steps, launch) -> dict[str, NDArray]:
    """Pack ``batch``, run ``launch`` (a batch reset-time kernel) on it, return its columns.

    ``launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out)`` fills the
    columns of :func:`empty_reset_columns` in ``out`` and a status code per valid row in
    ``codes``; invalid designs keep their design status.
    """
    out = empty_reset_columns(batch)
    status = out["status"]
    n = len(batch)
    if n == 0:
        return out
    unit_params, h, n_units = pack_batch(batch)
    valid = status == st.OK
    knot_t, knot_p = profile.knots()
    ctrl = controls(
        info,
        t_release=profile.t_release,
        atol=atol,
        rtol=None,
        h_max=None,
        max_steps=max_steps,
        stop_when_reset=True,
    )
    codes = np.zeros(n, dtype=np.int64)
    previous = numba.set_parallel_chunksize(1)
    try:
        launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out)
    finally:
        numba.set_parallel_chunksize(previous)
    status[valid] = codes[valid].astype(np.int8)
    with np.errstate(invalid="ignore"):
        no_contact = unit_no_contact(batch)
    mark_no_contact(
        no_contact & valid[:, None],
        n_units,
        out["final_state"],
        out["reset_time"],
        out["snap_through"],
        out["snap_back"],
        out["unit_class"],
    )
    return out


def unit_no_contact(batch: DesignBatch) -> NDArray[np.bool_]:
    """Units whose reach ``d`` is clamped under the batch's constants set, shape (n, MAX_UNITS).

    False on the padding (its NaN reach compares false).
    """
    with np.errstate(invalid="ignore"):
        return batch.constants.springs(
            batch.H,
            batch.t[:, None],
            batch.r_b[:, None],
            batch.E[:, None],
            batch.U_sep,
            batch.t_ch[:, None],
        )["no_contact"]
