"""Pressure windows of a finger's sequential states under a slow pressure ramp.

The one place where inverse design reads snap pressures. They come from the quasi-static
continuation of :mod:`dpfexplore.solvers.snap` (``snap_pressures``: the equilibrium followed under
the non-conservative pressure load of MODEL.md §8, with fold detection). Where that module is not
installed, the windows are reported as not computed, never guessed.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence

from ..model.design import Design
from .evaluation import Evaluator

__all__ = ["pressure_windows", "snap_available", "window_widths"]


def _snap_module():
    try:
        return importlib.import_module("dpfexplore.solvers.snap")
    except ImportError:
        return None


def snap_available() -> bool:
    """Whether the snap-pressure continuation is available."""
    return _snap_module() is not None


def pressure_windows(design: Design, states: Sequence[str], evaluator: Evaluator,
                     *, P_max: float = 1.0) -> dict:  # fmt: skip
    """Windows ``(P_enter, P_leave)`` (kPa) of ``states`` met in order under a rising pressure.

    Returns
    -------
    dict
        ``"computed"`` (bool), ``"sequence"`` (states visited, in order), ``"windows"``
        (one ``[P_enter, P_leave]`` in kPa per targeted state, None where not visited),
        ``"in_order"`` (the targeted states are visited in the given order) and ``"note"``.
    """
    module = _snap_module()
    if module is None:
        return {"computed": False, "sequence": None, "windows": [None] * len(states),
                "in_order": None,
                "note": "not computed: dpfexplore.solvers.snap is not installed"}  # fmt: skip
    seq = module.snap_pressures(design, P_max=P_max, direction="up")
    evaluator.count("snap")
    visited = list(seq.states)
    windows = []
    for state in states:
        if state in visited:
            low, high = seq.windows[visited.index(state)]
            windows.append([1000.0 * float(low), 1000.0 * float(high)])
        else:
            windows.append(None)
    positions = [visited.index(s) for s in states if s in visited]
    in_order = len(positions) == len(states) and positions == sorted(positions)
    return {"computed": True, "sequence": visited, "windows": windows, "in_order": in_order,
            "note": "quasi-static continuation under a slow ramp (dpfexplore.solvers.snap)"}


def window_widths(design: Design, states: Sequence[str], evaluator: Evaluator) -> list[float]:
    """Width (kPa) of each targeted state's window; ``-inf`` where it is not visited in order.

    Needs the snap-pressure continuation (:func:`snap_available`).
    """
    report = pressure_windows(design, states, evaluator)
    if not report["computed"]:
        raise RuntimeError(report["note"])
    if not report["in_order"]:
        return [-float("inf")] * len(states)
    return [w[1] - w[0] if w is not None else -float("inf") for w in report["windows"]]
