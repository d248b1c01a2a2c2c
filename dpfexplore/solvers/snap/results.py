"""Results of the slow-ramp continuation: events, visited states and their pressure windows.

Built by :func:`~dpfexplore.solvers.snap.continuation.snap_pressures`; plain data with JSON
summaries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...model import status as st
from ...model.design import Design
from ...model.formatting import json_number

__all__ = ["SnapEvent", "SnapSequence", "StateVisit"]


@dataclass(frozen=True)
class SnapEvent:
    """One change of state on a slow ramp.

    Attributes
    ----------
    pressure : float, MPa
        Fold pressure of a snap, or the pressure of a smooth crossing.
    kind : {"snap", "crossing", "unsettled"}
        ``"unsettled"``: a fold past which the motion did not come to rest within the landing's
        budget (1200 s of motion at up to 1 kPa past the fold): the load is not conservative,
        and past some folds of strongly curled fingers the motion is a slow relaxation
        oscillation. The walk stops there (status ``NOT_CONVERGED``); ``after`` is "".
    direction : {"up", "down"}
        Rising or falling pressure.
    before, after : str
        States (unit 1 first) just before and after.
    x_before, x_after : ndarray of shape (4N - 2,), mm
        Shapes: at the fold and where the finger lands (the same point for a crossing).
    settle_time : float, s
        Motion simulated before the landing was accepted (0 for a crossing).
    landing_steps : int
        Rodas4 steps of the landing.
    landing_offset : float, MPa
        How far past the fold the landing's motion ran: 1e-8 MPa, or 1e-5 / 1e-3 MPa where the
        fold is so flat that the motion had not settled after 400 s (0 for a crossing).
    decay_rate : float, 1/s
        Slowest decay rate of the linearised motion about the landing state (positive: stable;
        ``inf`` where not checked: crossings, or ``verify=False``).
    """

    pressure: float
    kind: str
    direction: str
    before: str
    after: str
    x_before: NDArray
    x_after: NDArray
    settle_time: float
    landing_steps: int
    decay_rate: float
    landing_offset: float = 0.0

    @property
    def inverted(self) -> tuple[int, ...]:
        """Units (1-based) inverted by this event."""
        if not self.after:
            return ()
        return tuple(
            k + 1
            for k, (a, b) in enumerate(zip(self.before, self.after, strict=True))
            if a == "0" and b == "1"
        )

    @property
    def reverted(self) -> tuple[int, ...]:
        """Units (1-based) that snapped back in this event."""
        if not self.after:
            return ()
        return tuple(
            k + 1
            for k, (a, b) in enumerate(zip(self.before, self.after, strict=True))
            if a == "1" and b == "0"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no shapes)."""
        return {
            "pressure": self.pressure,
            "kind": self.kind,
            "direction": self.direction,
            "before": self.before,
            "after": self.after,
            "inverted": list(self.inverted),
            "reverted": list(self.reverted),
            "settle_time_s": self.settle_time,
            "landing_offset_MPa": self.landing_offset,
            "decay_rate": json_number(self.decay_rate),
        }


@dataclass(frozen=True)
class StateVisit:
    """A state the finger sits in during one walk, and its pressure window.

    Attributes
    ----------
    state : str
    direction : {"up", "down"}
    P_enter, P_leave : float, MPa
        The window ``[P_enter, P_leave)`` (for a falling walk ``(P_leave, P_enter]``); NaN
        ``P_leave``: still in this state at the end of the walk.
    entered_by, left_by : str or None
        ``"start"``, ``"turn"`` (a cycle's falling walk), ``"snap"``, ``"crossing"``;
        ``left_by`` None if not left.
    released : str or None
        Rising walks with ``release=True``: the state reached when the pressure is slowly let
        down to ``P_min`` from inside the window (None if that walk failed).
    P_release_leave : float, MPa
        Where that release leaves this state (its first event; NaN: the state lasts to
        ``P_min``). The state exists (is stable) on ``[P_release_leave, P_leave)``.
    """

    state: str
    direction: str
    P_enter: float
    P_leave: float
    entered_by: str
    left_by: str | None
    released: str | None = None
    P_release_leave: float = math.nan

    @property
    def width(self) -> float:
        """``|P_leave - P_enter|`` (MPa); NaN when the state is not left."""
        return abs(self.P_leave - self.P_enter)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "state": self.state,
            "direction": self.direction,
            "P_enter": self.P_enter,
            "P_leave": json_number(self.P_leave),
            "entered_by": self.entered_by,
            "left_by": self.left_by,
            "released": self.released,
            "P_release_leave": json_number(self.P_release_leave),
        }


@dataclass(frozen=True)
class SnapSequence:
    """A finger's states and snaps under a slow pressure ramp (:func:`snap_pressures`).

    Attributes
    ----------
    design : Design
    direction : {"up", "down", "cycle"}
    P_start, P_max, P_min : float, MPa
    status : Status
        ``OK`` when every walk reached its end; otherwise the first failure (the events before
        it are valid).
    events : tuple of SnapEvent
        In the order they happen.
    visits : tuple of StateVisit
        The states in the order visited, with their windows.
    path : dict of str to ndarray
        The branches as followed, for plots: ``"P"`` (MPa), ``"segment"`` (a new one after
        each snap and at the turn of a cycle), ``"state"`` (int, unit 1 = most significant bit),
        ``"tip"`` (rows of x, y in mm), ``"u"`` (rows of the units' ``u = x̄/d``).
    final_x : ndarray of shape (4N - 2,), mm
        Shape at the end of the last walk.
    model : str
        Landing model.
    fitted_range : bool
        Whether the design is inside the fitted domain of the closed forms (MODEL.md §3,
        :data:`dpfexplore.model.domain.FITTED_RANGES`); results outside it are the model's,
        not trusted physics.
    no_contact : tuple of bool
        Per unit: the closed form of the dome's reach was not positive (MODEL.md §3, ``d``
        clamped to 0.01 mm). Such a dome cannot bend the finger, and its "inversion" over a
        0.01 mm reach is the model's artefact: its events happen at a few kPa.
    stats : dict
        Continuation steps (accepted, rejected), landing steps, events.
    """

    design: Design
    direction: str
    P_start: float
    P_max: float
    P_min: float
    status: st.Status
    events: tuple[SnapEvent, ...]
    visits: tuple[StateVisit, ...]
    path: dict[str, NDArray]
    final_x: NDArray
    model: str
    fitted_range: bool
    no_contact: tuple[bool, ...] = ()
    stats: dict[str, int] = field(default_factory=dict)

    @property
    def snaps(self) -> tuple[SnapEvent, ...]:
        """The snap events only."""
        return tuple(e for e in self.events if e.kind == "snap")

    def inversion_pressures(self) -> NDArray[np.float64]:
        """First pressure (MPa) at which each unit is inverted on the rising walk.

        Shape ``(N,)``; ``inf`` if not by the end of the ramp, 0 (the start pressure) if
        inverted at the start; NaN if the walk failed before inverting it.
        """
        n = self.design.n_units
        out = np.full(n, np.inf if self.status == st.OK else np.nan)
        start = self.visits[0].state if self.visits else "0" * n
        for k in range(n):
            if start[k] == "1":
                out[k] = self.P_start
        for event in self.events:
            if event.direction != "up":
                continue
            for unit in event.inverted:
                if not math.isfinite(out[unit - 1]) or out[unit - 1] > event.pressure:
                    out[unit - 1] = event.pressure
        return out

    def release_windows(self) -> dict[str, list[tuple[float, float]]]:
        """Pressure windows (MPa) of a rising walk from which a release ends in each state.

        ``{"10000": [(0.113, 0.179)], ...}``: ramping up to a pressure inside one of the
        windows and slowly back to ``P_min`` leaves the finger in that state. Adjacent windows
        with the same outcome are merged; an open last window ends at ``P_max``.
        """
        out: dict[str, list[tuple[float, float]]] = {}
        for visit in self.visits:
            if visit.direction != "up" or visit.released is None:
                continue
            hi = visit.P_leave if math.isfinite(visit.P_leave) else self.P_max
            windows = out.setdefault(visit.released, [])
            if windows and windows[-1][1] == visit.P_enter:
                windows[-1] = (windows[-1][0], hi)
            else:
                windows.append((visit.P_enter, hi))
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "design": self.design.to_dict(),
            "direction": self.direction,
            "P_start": self.P_start,
            "P_max": self.P_max,
            "P_min": self.P_min,
            "status": self.status.label,
            "model": self.model,
            "fitted_range": self.fitted_range,
            "no_contact": list(self.no_contact),
            "events": [e.to_dict() for e in self.events],
            "states": [v.to_dict() for v in self.visits],
            "inversion_pressures": [json_number(v) for v in self.inversion_pressures()],
            "release_windows": {k: [list(w) for w in v] for k, v in self.release_windows().items()},
            "stats": dict(self.stats),
        }
