"""Inversion pressures of units within their finger: the one place the timing scenes read them.

A unit's inversion pressure is the pressure at which it first inverts when the chamber pressure
rises quasi-statically from 0 (the finger flat): by a snap at a fold of the loaded equilibrium
branch, or by a smooth crossing of its threshold along the branch. It comes from the pressure
continuation of :mod:`dpfexplore.solvers.snap.continuation` (``inversion_pressures_batch``: the
equilibrium followed under the non-conservative pressure load of MODEL.md §8, folds located,
landings simulated), a few milliseconds per design, counted as ``snap`` evaluations. (Until that
branch landed these came from two slow-ramp simulations extrapolated to the quasi-static limit,
:func:`dpfexplore.solvers.dynamics.ramp.inversion_pressures`; the tests still compare the two.)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design, DesignBatch
from ....solvers.snap.batch import inversion_pressures_batch
from ...evaluation import SceneEvaluator

__all__ = ["METHOD", "inversion_method", "unit_inversion_pressures"]

#: How the inversion pressures are computed (reported with them).
METHOD = (
    "quasi-static continuation of the loaded equilibrium (dpfexplore.solvers.snap.continuation)"
)


def inversion_method() -> str:
    """How inversion pressures are computed here (for reports)."""
    return METHOD


def unit_inversion_pressures(
    designs: Sequence[Design], evaluator: SceneEvaluator, *, P_max: float = 1.0
) -> NDArray[np.float64]:
    """First inversion pressure (MPa) of every unit under a slowly rising pressure.

    Parameters
    ----------
    designs : sequence of Design
    evaluator : SceneEvaluator
        Counts the continuations (``snap``, one per design).
    P_max : float, MPa
        End of the rise; units still flat there get ``inf``.

    Returns
    -------
    ndarray of shape (len(designs), max N), MPa
        ``inf`` for units that do not invert below ``P_max``; NaN where the continuation failed
        and on padding.
    """
    designs = list(designs)
    width = max((d.n_units for d in designs), default=0)
    out = np.full((len(designs), width), np.nan)
    if not designs:
        return out
    values = inversion_pressures_batch(DesignBatch.from_designs(designs), P_max=P_max)
    evaluator.count("snap", len(designs))
    for i, design in enumerate(designs):
        out[i, : design.n_units] = values[i, : design.n_units]
    return out
