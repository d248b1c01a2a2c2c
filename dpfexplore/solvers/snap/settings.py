"""Settings and checks shared by the snap walks of one design and of a batch.

The ramp's default end, the landing models and their Rodas4 settings, the kernels' output
capacities, and the checks of the pressures and the kick every entry point takes
(:mod:`.continuation` for one design, :mod:`.batch` for many).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics.motion import ETA_INTERNAL, ETA_ISO, node_mass
from ...model.domain import MAX_UNITS
from ...model.pressure import MAX_PRESSURE
from ..dynamics.common import METHODS, controls

__all__ = [
    "DEFAULT_P_MAX",
    "EVENT_CAPACITY",
    "LANDING_ATOL",
    "LANDING_H_MAX",
    "LANDING_MODELS",
    "PATH_CAPACITY",
    "check_kick",
    "check_pressure",
    "landing_model",
]

#: Default end of the rising ramp, MPa.
DEFAULT_P_MAX = 1.0
#: Models that can decide a landing (names of :data:`~dpfexplore.solvers.dynamics.common.METHODS`).
LANDING_MODELS = ("rodas4", "rodas4-overdamped")
#: Rodas4 position tolerance of the landings, mm (module docstring), and largest step, s: a
#: landing has no events to resolve, and the motion settles over tens of seconds in soft fingers
#: (the simulations' 0.5 s cap made that hundreds of steps).
LANDING_ATOL = 3e-3
LANDING_H_MAX = 100.0
#: Events kept per walk.
EVENT_CAPACITY = 4 * MAX_UNITS
#: Branch points kept per walk (for plots).
PATH_CAPACITY = 5_000


def check_pressure(name: str, value) -> float:
    """``value`` as a finite pressure (MPa) within the model's range, else a named error."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: must be a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} = {value!r}: must be finite")
    if abs(value) > MAX_PRESSURE:  # the range every other entry point holds (model.pressure)
        raise ValueError(
            f"{name} = {value:g} MPa: beyond ±{MAX_PRESSURE:g} MPa, the most the model takes"
        )
    return value


def check_kick(kick) -> float:
    """The kick (mm) for the kernels: 0 selects their default."""
    if kick is None:
        return 0.0
    kick = check_pressure("kick", kick)
    if not kick > 0.0:
        raise ValueError(f"kick = {kick}: must be > 0 mm")
    return kick


def landing_model(model: str, n_units: int) -> tuple[NDArray, NDArray]:
    """``phys`` and Rodas4 ``ctrl`` of the landings."""
    if model not in LANDING_MODELS:
        raise ValueError(f"model = {model!r}: choose one of {LANDING_MODELS}")
    mass = 0.0 if model == "rodas4-overdamped" else node_mass(n_units)
    ctrl = controls(
        METHODS[model],
        t_release=0.0,
        atol=LANDING_ATOL,
        rtol=None,
        h_max=LANDING_H_MAX,
        max_steps=None,
        stop_when_reset=False,
    )
    return np.array([ETA_INTERNAL, ETA_ISO, mass]), ctrl
