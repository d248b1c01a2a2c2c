"""Inversion pressures of units within their finger: the one place inverse design reads them.

A unit's inversion pressure is the pressure at which it first snaps through when the chamber
pressure rises quasi-statically from 0 (the finger flat). Where the pressure continuation of
:mod:`dpfexplore.solvers.snap` is installed it gives them (``snap_pressures``: the equilibrium
followed under the non-conservative pressure load of MODEL.md §8 with fold detection; counted as
``snap`` evaluations); until then they come from two slow-ramp simulations extrapolated to the
quasi-static limit (:func:`dpfexplore.solvers.ramp.inversion_pressures`, within about 1 %;
counted as ``simulations``, two per design, run in parallel over a batch). Switching to the
continuation is this module only.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..model.design import Design, DesignBatch
from .evaluation import Evaluator

__all__ = ["inversion_method", "snap_available", "unit_inversion_pressures"]

_RAMPS = ("slow-ramp simulations extrapolated to the quasi-static limit "
          "(dpfexplore.solvers.ramp)")  # fmt: skip
_SNAP = "quasi-static continuation (dpfexplore.solvers.snap)"


def _snap_module():
    try:
        return importlib.import_module("dpfexplore.solvers.snap")
    except ImportError:
        return None


def snap_available() -> bool:
    """Whether the snap-pressure continuation is available (fast enough for a search loop)."""
    return _snap_module() is not None


def inversion_method() -> str:
    """How inversion pressures are computed here (for reports)."""
    return _SNAP if snap_available() else _RAMPS


def unit_inversion_pressures(designs: Sequence[Design], evaluator: Evaluator, *,
                             P_max: float = 1.0) -> NDArray[np.float64]:  # fmt: skip
    """First snap-through pressure (MPa) of every unit under a slowly rising pressure.

    Parameters
    ----------
    designs : sequence of Design
    evaluator : Evaluator
        Counts the work (``snap`` per design, or ``simulations``: two ramps per design).
    P_max : float, MPa
        End of the rise; units still flat there get NaN.

    Returns
    -------
    ndarray of shape (len(designs), max N), MPa
        NaN for units that do not invert below ``P_max``, no-contact units and padding.
    """
    designs = list(designs)
    width = max((d.n_units for d in designs), default=0)
    out = np.full((len(designs), width), np.nan)
    if not designs:
        return out
    module = _snap_module()
    if module is not None:
        for i, design in enumerate(designs):
            seq = module.snap_pressures(design, P_max=P_max, direction="up")
            evaluator.count("snap")
            for event in seq.events:
                for unit in event.units:
                    if math.isnan(out[i, unit - 1]):
                        out[i, unit - 1] = float(event.pressure)
        return out
    from ..solvers.ramp import inversion_pressures

    values = inversion_pressures(DesignBatch.from_designs(designs), P_max=P_max)
    evaluator.count("simulations", 2 * len(designs))
    for i, design in enumerate(designs):
        out[i, : design.n_units] = values[i, : design.n_units]
    return out
