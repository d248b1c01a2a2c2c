"""Chamber pressure against time: the paper's τ1-τ4 pulse and any piecewise-linear profile.

A :class:`PressureProfile` is data (knot times and pressures) that the integrators read as two
arrays; its last knot, ``t_release``, is where reset times are measured from (MODEL.md §8).

Validation lives here and only here: the CLI (``--P0``, ``--tau``, ``--profile``), job files
(``[compute.reset_times]``) and the Python API all build a :class:`PressureProfile`, so every
entry point accepts and refuses the same profiles with the same one-line message.

Physical range: ``0 <= P <= MAX_PRESSURE`` (2 MPa) at every knot, times ``>= 0`` s.
    * ``P >= 0``: the model's load (MODEL.md §8) is the inflation of the chambers, pressure
      times face length pushing every face outward; the dome inversion it tracks is driven by
      that. A negative (vacuum) pressure is not the load the model describes.
    * ``P <= 2 MPa``: the paper runs its fingers at 0.4-0.7 MPa. At 2 MPa a thin-wall estimate
      of the chamber-wall stress, ``P (UC/2) / t_ch`` = 7.5 P for the paper's 15 mm cells and
      1 mm walls, is 15 MPa, past the yield of the printable TPUs the model is for; the strain
      of the walls, about that stress over ``E`` (0.6 at E = 26 MPa), is far outside the small
      strains in which the lattice's linear springs and the fitted dome constants mean
      anything. 2 MPa is also below the smallest modulus the closed forms were fitted for
      (5 MPa, :data:`dpfexplore.model.domain.FITTED_RANGES`), so ``P`` stays below ``E`` for
      every material in the fitted range.
    * times ``>= 0``: a run starts at rest at ``t = 0``; knots before that would only change
      the pressure at the start.
    * a pulse's plateau ``P0`` must be ``> 0``: a pulse of zero pressure is no pulse (a
      profile of knots may hold zero anywhere).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .formatting import nums

__all__ = ["MAX_PRESSURE", "PressureProfile"]

#: Largest chamber pressure of a profile, MPa (module docstring: why 2 MPa).
MAX_PRESSURE = 2.0


def _check_pressure(name: str, value: float, *, plateau: bool = False) -> None:
    low = "> 0" if plateau else ">= 0"
    if not math.isfinite(value) or value < 0.0 or (plateau and value == 0.0):
        raise ValueError(
            f"{name} = {value!r}: must be a finite pressure {low} MPa (at most {MAX_PRESSURE:g})"
        )
    if value > MAX_PRESSURE:
        raise ValueError(
            f"{name} = {value!r}: above {MAX_PRESSURE:g} MPa, the most the model takes (chamber "
            "walls would be far past yield; see dpfexplore.model.pressure)"
        )


def _check_time(name: str, value: float) -> None:
    if not math.isfinite(value) or value < 0.0:
        raise ValueError(f"{name} = {value!r}: must be a finite time >= 0 s (runs start at 0)")


@dataclass(frozen=True, init=False)
class PressureProfile:
    """Piecewise-linear chamber pressure ``P(t)`` (MPa against s).

    Before the first knot the first pressure holds, after the last knot the last one. The end
    of the profile, ``t_release`` (the last knot), is where reset times are measured from.

    ``PressureProfile(times, pressures)`` takes knots; ``PressureProfile(P0=0.7,
    tau=(0, 1, 5, 5.1))`` is the paper's single pulse (same as :meth:`pulse`).

    Parameters
    ----------
    times : sequence of float, s
        Knot times, non-decreasing (equal times make a step).
    pressures : sequence of float, MPa
        Pressure at each knot.
    P0 : float, MPa, keyword-only
        Plateau pressure of a single pulse (instead of knots).
    tau : sequence of 4 floats, s, keyword-only
        ``τ1 <= τ2 <= τ3 <= τ4`` of that pulse.

    Raises
    ------
    ValueError
        Naming the field, for empty, non-finite, negative, decreasing or mismatched knots and
        pressures outside ``[0, MAX_PRESSURE]`` (module docstring).
    """

    times: tuple[float, ...]
    pressures: tuple[float, ...]

    def __init__(
        self,
        times: Sequence[float] | None = None,
        pressures: Sequence[float] | None = None,
        *,
        P0: float | None = None,
        tau: Sequence[float] | None = None,
    ) -> None:
        if P0 is not None or tau is not None:
            if times is not None or pressures is not None:
                raise ValueError("give either knots (times, pressures) or a pulse (P0, tau)")
            if P0 is None or tau is None:
                raise ValueError(f"P0 = {P0!r}, tau = {tau!r}: a pulse needs both")
            pulse = PressureProfile.pulse(P0, tau)
            times, pressures = pulse.times, pulse.pressures
        if times is None or pressures is None:
            raise ValueError("times, pressures: a pressure profile needs knots (or P0 and tau)")
        times = tuple(float(v) for v in np.ravel(times))
        pressures = tuple(float(v) for v in np.ravel(pressures))
        if not times:
            raise ValueError("times = (): a pressure profile needs at least one knot")
        if len(times) != len(pressures):
            raise ValueError(
                f"pressures = {nums(pressures)}: {len(pressures)} values for {len(times)} times"
            )
        for i, v in enumerate(times):
            _check_time(f"times[{i}]", v)
        for i, v in enumerate(pressures):
            _check_pressure(f"pressures[{i}]", v)
        if any(b < a for a, b in pairwise(times)):
            raise ValueError(f"times = {nums(times)}: must be non-decreasing")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "pressures", pressures)

    @classmethod
    def pulse(cls, P0: float, tau: Sequence[float]) -> PressureProfile:
        """The paper's pulse: 0 until ``τ1``, up to ``P0`` at ``τ2``, held to ``τ3``, 0 at ``τ4``.

        Parameters
        ----------
        P0 : float, MPa
        tau : sequence of 4 floats, s
            ``τ1 <= τ2 <= τ3 <= τ4``.
        """
        if np.ndim(tau) != 1 or len(tau) != 4:
            shown = nums(tau) if np.ndim(tau) == 1 else repr(tau)
            raise ValueError(f"tau = {shown}: need four times tau1, tau2, tau3, tau4 (s)")
        return cls.pulses([(P0, *tau)])

    @classmethod
    def pulses(cls, pulses: Sequence[Sequence[float]]) -> PressureProfile:
        """Several trapezoidal pulses ``(P0, τ1, τ2, τ3, τ4)`` in time order, not overlapping."""
        times: list[float] = []
        pressures: list[float] = []
        last_end = -math.inf
        for i, pulse in enumerate(pulses):
            if len(pulse) != 5:
                raise ValueError(f"pulses[{i}] = {nums(pulse)}: need (P0, tau1, tau2, tau3, tau4)")
            P0, *tau = (float(v) for v in pulse)
            _check_pressure("P0", P0, plateau=True)
            for k, v in enumerate(tau):
                _check_time(f"tau[{k}]", v)
            if any(b < a for a, b in pairwise(tau)):
                raise ValueError(f"tau = {nums(tau)}: need tau1 <= tau2 <= tau3 <= tau4 (s)")
            if tau[0] < last_end:
                raise ValueError(
                    f"pulses[{i}] starts at tau1 = {tau[0]} s, before the previous pulse ends "
                    f"({last_end} s)"
                )
            times += tau
            pressures += [0.0, P0, P0, 0.0]
            last_end = tau[3]
        if not times:
            raise ValueError("pulses = []: give at least one pulse")
        return cls(tuple(times), tuple(pressures))

    @classmethod
    def parse(cls, text: str) -> PressureProfile:
        """Read ``"t:P, t:P, ..."`` knots (s:MPa), e.g. ``"0:0, 1:0.7, 5:0.7, 5.1:0"``."""
        times, pressures = [], []
        for item in text.split(","):
            try:
                t_text, p_text = item.split(":")
                times.append(float(t_text))
                pressures.append(float(p_text))
            except ValueError:
                raise ValueError(
                    f"profile = {text!r}: write knots as 'time:pressure' separated by commas"
                ) from None
        return cls(tuple(times), tuple(pressures))

    @property
    def t_release(self) -> float:
        """End of the profile (the last knot, ``τ_end``), s."""
        return self.times[-1]

    def zero_until(self) -> float:
        """End of the initial stretch without pressure, s.

        The largest ``T`` such that ``P(t) = 0`` for every ``t < T``: the knot before the first
        non-zero pressure (``inf`` if the pressure is always 0, ``-inf`` if it starts non-zero).
        A finger at rest stays at rest until then, so its integration can start there.
        """
        nonzero = [i for i, p in enumerate(self.pressures) if p != 0.0]
        if not nonzero:
            return math.inf
        if nonzero[0] == 0:
            return -math.inf
        return self.times[nonzero[0] - 1]

    def knots(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Knot arrays ``(times, pressures)`` for the kernels."""
        return np.array(self.times), np.array(self.pressures)

    def __call__(self, t: Any) -> NDArray[np.float64]:
        """Pressure (MPa) at times ``t`` (s)."""
        return np.interp(t, self.times, self.pressures)
