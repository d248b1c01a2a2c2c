"""Pressure windows of a gripper's grasp states under a slow pressure ramp.

The one place where inverse design reads snap pressures. A grasp state (e.g. ``11000``) is held
by the finger once the pressure has been raised into its *window* and slowly released: the
window is the pressure interval of a rising ramp from which a release ends in that state
(:meth:`dpfexplore.solvers.snap.results.SnapSequence.release_windows`). The states must be met
in their given order (their windows rising), and each window must be wide enough for a
controller to hit (the scene's ``min_window_kPa``).

Release windows rather than the loaded states' windows, because a metastable tip unit (the
gripper's unit 5) is inverted only while the pressure is on: under the gripper's rising ramp
the tip unit snaps first (``00001``), then units 1-4 (``10001``, ``11001``, ...), and each loaded
state releases into the grasp state with the tip unit reset (``10000``, ``11000``, ...).

Snap pressures come from the quasi-static continuation of
:mod:`dpfexplore.solvers.snap.continuation` (the equilibrium followed under the non-conservative
pressure load of MODEL.md §8, folds located, landings decided by the dynamics): a few milliseconds
per design, counted as ``snap`` evaluations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import pairwise
from typing import TypedDict

import numpy as np

from ....model.design import Design
from ....solvers.snap.continuation import snap_pressures
from ...evaluation import SceneEvaluator

__all__ = ["METHOD", "PressureWindows", "pressure_windows", "window_widths"]

#: How the windows are computed (reported with them).
METHOD = "quasi-static continuation with release (dpfexplore.solvers.snap.continuation)"


class PressureWindows(TypedDict):
    """The pressure windows of a design's grasp states (:func:`pressure_windows`), kPa."""

    computed: bool
    method: str
    unit_pressures_kPa: list[float | None]
    sequence: list[str]
    windows: list[list[float] | None]
    in_order: bool
    note: str


def pressure_windows(
    design: Design, states: Sequence[str], evaluator: SceneEvaluator, *, P_max: float = 1.0
) -> PressureWindows:
    """Windows ``[P_enter, P_leave]`` (kPa) from which a slow release leaves each of ``states``.

    Returns
    -------
    PressureWindows
        ``"computed"`` (the continuation reached ``P_max``), ``"method"``,
        ``"unit_pressures_kPa"`` (first inversion of every unit on the rising ramp; None where
        not by ``P_max``), ``"sequence"`` (the states the rising ramp visits), ``"windows"``
        (one ``[P_enter, P_leave]`` per state, the first if several, None where no release ends
        in it), ``"in_order"`` (every state has a window and the windows rise in the given
        order) and a ``"note"``.
    """
    seq = snap_pressures(design, P_max=P_max, direction="up")
    evaluator.count("snap")
    released = seq.release_windows()
    windows = []
    notes = [METHOD]
    for state in states:
        found = released.get(state)
        windows.append([1000.0 * found[0][0], 1000.0 * found[0][1]] if found else None)
        if found and len(found) > 1:
            notes.append(f"{state} is also released from {len(found) - 1} later window(s)")
    lows = [w[0] for w in windows if w is not None]
    in_order = len(lows) == len(states) and all(b > a for a, b in pairwise(lows))
    pressures = seq.inversion_pressures()
    if windows and windows[-1] is not None and windows[-1][1] >= 1000.0 * P_max:
        notes.append(f"the last window is open above (to {1000 * P_max:g} kPa)")
    if seq.status.label != "ok":
        notes.append(f"the continuation ended early ({seq.status.label})")
    return {
        "computed": seq.status.label == "ok",
        "method": METHOD,
        "unit_pressures_kPa": [1000.0 * p if np.isfinite(p) else None for p in pressures],
        "sequence": [v.state for v in seq.visits if v.direction == "up"],
        "windows": windows,
        "in_order": bool(in_order),
        "note": "; ".join(notes),
    }


def window_widths(design: Design, states: Sequence[str], evaluator: SceneEvaluator) -> list[float]:
    """Width (kPa) of each state's window; ``-inf`` everywhere when they are not met in order."""
    report = pressure_windows(design, states, evaluator)
    if not report["in_order"]:
        return [-math.inf] * len(states)
    return [w[1] - w[0] for w in report["windows"]]
