"""Pressure windows of a finger's sequential states under a slow pressure ramp.

The one place where inverse design reads snap pressures. A targeted state (e.g. ``11000``) is
entered when the last of its inverted units snaps and left when the next unit of the sequence
snaps; its window is that pressure interval, and the states must be met in their given order.
The last state's window is open above (to the ramp's end, ``P_max``). Units inverted in no
targeted state (the gripper's metastable tip unit) are left out of the sequence: such a unit may
snap during the ramp, but it resets when the pressure is released, and the bistable units alone
set the state the finger keeps.

Snap pressures come from the quasi-static continuation of :mod:`dpfexplore.solvers.snap` where it
is installed (``snap_pressures``: the equilibrium followed under the non-conservative pressure
load of MODEL.md §8, with fold detection), else from slow-ramp simulations extrapolated to the
quasi-static limit (:func:`dpfexplore.solvers.ramp.inversion_pressures`: two full-model runs,
counted as simulations), which is too slow to sit inside an optimisation loop but checks every
final design.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence

import numpy as np

from ..model.design import Design, DesignBatch
from .evaluation import Evaluator

__all__ = ["pressure_windows", "snap_available", "window_widths"]


def _snap_module():
    try:
        return importlib.import_module("dpfexplore.solvers.snap")
    except ImportError:
        return None


def snap_available() -> bool:
    """Whether the snap-pressure continuation is available (fast enough for the loop)."""
    return _snap_module() is not None


def _unit_pressures(design: Design, evaluator: Evaluator, P_max: float) -> tuple[list, str]:
    """First snap pressure (MPa) of every unit under a rising pressure, and the method."""
    module = _snap_module()
    n = design.n_units
    if module is not None:
        seq = module.snap_pressures(design, P_max=P_max, direction="up")
        evaluator.count("snap")
        pressures = [math.nan] * n
        for event in seq.events:
            for unit in event.units:
                if math.isnan(pressures[unit - 1]):
                    pressures[unit - 1] = float(event.pressure)
        return pressures, "quasi-static continuation (dpfexplore.solvers.snap)"
    from ..solvers.ramp import inversion_pressures

    values = inversion_pressures(DesignBatch.from_designs([design]), P_max=P_max)[0, :n]
    evaluator.count("simulations", 2)
    return [float(v) for v in values], ("slow-ramp simulations extrapolated to the quasi-static "
                                        "limit (dpfexplore.solvers.ramp)")  # fmt: skip


def pressure_windows(design: Design, states: Sequence[str], evaluator: Evaluator,
                     *, P_max: float = 1.0) -> dict:  # fmt: skip
    """Windows ``[P_enter, P_leave]`` (kPa) of ``states`` met in order under a rising pressure.

    Returns
    -------
    dict
        ``"computed"``, ``"method"``, ``"unit_pressures_kPa"`` (first snap of every unit),
        ``"sequence"`` (the targeted units' snap order as states), ``"windows"`` (one
        ``[P_enter, P_leave]`` per targeted state, None where not met), ``"in_order"`` and a
        ``"note"``.
    """
    pressures, method = _unit_pressures(design, evaluator, P_max)
    n = design.n_units
    units = sorted({k for s in states for k in range(n) if s[k] == "1"})
    snapped = [k for k in units if np.isfinite(pressures[k])]
    order = sorted(snapped, key=lambda k: pressures[k])
    sequence, bits = [], ["0"] * n
    for k in order:
        bits[k] = "1"
        sequence.append("".join(bits))
    windows = []
    for state in states:
        if state in sequence:
            i = sequence.index(state)
            enter = pressures[order[i]]
            leave = pressures[order[i + 1]] if i + 1 < len(order) else P_max
            windows.append([1000.0 * enter, 1000.0 * leave])
        else:
            windows.append(None)
    positions = [sequence.index(s) for s in states if s in sequence]
    in_order = len(positions) == len(states) and positions == sorted(positions)
    others = [k for k in range(n) if k not in units and np.isfinite(pressures[k])]
    note = method
    if others:
        note += "; " + ", ".join(f"unit {k + 1} (inverted in no targeted state) snaps at "
                                 f"{1000 * pressures[k]:.1f} kPa" for k in others)  # fmt: skip
    if windows and windows[-1] is not None:
        note += f"; the last window is open above (to {1000 * P_max:g} kPa)"
    return {"computed": True, "method": method,
            "unit_pressures_kPa": [1000.0 * p if np.isfinite(p) else None for p in pressures],
            "sequence": sequence, "windows": windows, "in_order": in_order,
            "note": note}  # fmt: skip


def window_widths(design: Design, states: Sequence[str], evaluator: Evaluator) -> list[float]:
    """Width (kPa) of each targeted state's window; ``-inf`` where it is not met in order."""
    report = pressure_windows(design, states, evaluator)
    if not report["in_order"]:
        return [-math.inf] * len(states)
    return [w[1] - w[0] if w is not None else -math.inf for w in report["windows"]]
