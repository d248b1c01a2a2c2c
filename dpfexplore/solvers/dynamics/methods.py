"""The ways of integrating the dynamics, by name: what the CLI offers without importing Numba.

:data:`METHODS` is read by ``dpfexplore simulate --help`` and ``reset-maps --help``; keeping it
apart from the kernels keeps ``dpfexplore --help`` from compiling or importing them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..._kernels.dynamics.ids import INTEGRATOR_DOPRI5, INTEGRATOR_RODAS4

__all__ = ["DEFAULT_METHOD", "METHODS", "MethodInfo"]


@dataclass(frozen=True)
class MethodInfo:
    """One way of integrating the dynamics.

    Attributes
    ----------
    name : str
    model : str
        ``"full"`` (masses), ``"overdamped"`` (inertia dropped), ``"release"`` (quasi-static
        loading, overdamped release) or ``"fast"`` (static loading, loose release, fitted
        correction and fallback: :mod:`dpfexplore.solvers.dynamics.fast_reset`).
    integrator : int
        Kernel id (-1: not a Numba integrator).
    atol : float, mm
        Default absolute tolerance on positions.
    max_steps : int
        Default cap on step attempts.
    h_max : float, s
        Default largest step.
    """

    name: str
    model: str
    integrator: int
    atol: float
    max_steps: int
    h_max: float


#: Available methods. Rodas4's default position tolerance, 1e-4 mm, keeps reset times within
#: 0.14 % of a tight reference (max over the metastable units of 100 random designs; 0.013 %
#: median) at 1.6-1.9 ms per design on one core of a shared 2-core machine; ``dpfexplore
#: bench dynamics`` gives the whole time-error curve (3e-4 mm: 0.6 % max, 1e-5 mm: 0.011 % max).
METHODS: dict[str, MethodInfo] = {
    "rodas4": MethodInfo("rodas4", "full", INTEGRATOR_RODAS4, 1e-4, 200_000, 0.5),
    "rodas4-overdamped": MethodInfo(
        "rodas4-overdamped", "overdamped", INTEGRATOR_RODAS4, 1e-4, 200_000, 0.5
    ),
    "dopri5": MethodInfo("dopri5", "full", INTEGRATOR_DOPRI5, 1e-3, 20_000_000, 0.5),
    "dopri5-overdamped": MethodInfo(
        "dopri5-overdamped", "overdamped", INTEGRATOR_DOPRI5, 1e-3, 2_000_000, 0.5
    ),
    "release": MethodInfo("release", "release", INTEGRATOR_RODAS4, 1e-4, 200_000, 0.5),
    # the fast model's own tolerance lives in its model file; this one is informative
    "fast": MethodInfo("fast", "fast", -1, 3e-3, 20_000, 5.0),
    "radau": MethodInfo("radau", "full", -1, 1e-9, 0, math.inf),
}
DEFAULT_METHOD = "rodas4"
