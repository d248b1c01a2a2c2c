"""Inversion pressures from slow pressure ramps: the simulation route beside the continuation.

A unit's inversion pressure within its finger is the pressure at which it snaps through when
the pressure rises quasi-statically from 0: the fold of the loaded equilibrium it sits on. Here
it is read off simulations (MODEL.md §8) under linear ramps ``P(t) = P_max t / T``: the pressure
at the unit's first upward crossing of its threshold. A ramp passes a fold late, by a pressure
that scales as the ramp rate to the power 2/3 (slow passage through a saddle-node), so two ramps,
of length ``T`` and ``4 T``, give the quasi-static value by Richardson extrapolation::

    P* = P(4T) - (P(T) - P(4T)) / (4^(2/3) - 1)

On the walker's sections and the pick-and-place finger the rule predicts a third ramp (``16 T``)
to 0.1-0.3 %, and holding the pressure at 0.99 ``P*`` for 90 s leaves the unit flat while
1.01 ``P*`` inverts it (``tests/solvers/test_ramp.py``). The pressure continuation
(:func:`dpfexplore.solvers.snap.continuation.inversion_pressure`, branch ``snap``) finds the
fold directly and is preferred where it applies; this route checks it with the full dynamics.

Each ramp is one :func:`~dpfexplore.solvers.dynamics.simulate.reset_times_batch` call
(parallel rows).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...model.design import DesignBatch
from ...model.pressure import PressureProfile
from .simulate import reset_times_batch

__all__ = ["RAMP_DURATION", "RAMP_P_MAX", "inversion_pressures", "ramp_snap_pressures"]

#: Default ramps: 0 to ``RAMP_P_MAX`` MPa over ``RAMP_DURATION`` s (0.025 MPa/s) and 4x longer.
RAMP_P_MAX = 1.0
RAMP_DURATION = 40.0
#: Exponent of the delay of a slow passage through a saddle-node against the ramp rate.
_DELAY_EXPONENT = 2.0 / 3.0


def ramp_snap_pressures(
    batch: DesignBatch,
    *,
    P_max: float = RAMP_P_MAX,
    duration: float = RAMP_DURATION,
    method: str = "rodas4",
) -> NDArray[np.float64]:
    """Pressure (MPa) at each unit's first snap-through under one linear ramp (not extrapolated).

    Parameters
    ----------
    batch : DesignBatch
    P_max : float, MPa
        End of the ramp; units that have not inverted by then get NaN.
    duration : float, s
        Length of the ramp (rate ``P_max / duration``).
    method : str
        Integrator of :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch`.

    Returns
    -------
    ndarray of shape (n, MAX_UNITS), MPa
        NaN for units that never invert below ``P_max``, no-contact units, padding and
        invalid or failed rows.
    """
    if not (np.isfinite(P_max) and P_max > 0 and np.isfinite(duration) and duration > 0):
        raise ValueError(f"P_max = {P_max!r}, duration = {duration!r}: need finite values > 0")
    profile = PressureProfile((0.0, duration, duration), (0.0, P_max, 0.0))
    out = reset_times_batch(batch, profile, t_end=duration, method=method)
    pressure = out["snap_through"] * (P_max / duration)
    pressure[out["status"] != 0] = np.nan
    return pressure


def inversion_pressures(
    batch: DesignBatch,
    *,
    P_max: float = RAMP_P_MAX,
    duration: float = RAMP_DURATION,
    method: str = "rodas4",
) -> NDArray[np.float64]:
    """Quasi-static inversion pressure (MPa) of each unit: two ramps, extrapolated.

    Parameters are those of :func:`ramp_snap_pressures` (``duration`` is the shorter ramp).

    Returns
    -------
    ndarray of shape (n, MAX_UNITS), MPa
        NaN where either ramp leaves the unit flat (or it has no contact).
    """
    fast = ramp_snap_pressures(batch, P_max=P_max, duration=duration, method=method)
    slow = ramp_snap_pressures(batch, P_max=P_max, duration=4.0 * duration, method=method)
    return slow - (fast - slow) / (4.0**_DELAY_EXPONENT - 1.0)
