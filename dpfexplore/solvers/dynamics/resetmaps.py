"""Reset-time maps: the paper's "Metastable dome unit analysis", from the lattice dynamics.

The paper's Fig. S metaUnit_Cell a-b and Fig. S Static_Unit_Cell c.

Three one-parameter maps of the reset time after release:

* against dome height ``H`` at thickness ``t = 0.8 mm`` (Fig. S a);
* against dome thickness ``t`` at ``H = 3.0 mm`` (Fig. S b);
* against the hold time ``τ3 - τ2`` (Fig. S Static_Unit_Cell c), for a few heights.

The finger is the paper's unit cell by default (``n_units = 1``: one dome, its two posts and
limiting layer, clamped at the base), or a finger of ``n_units`` equal units. Every unit of a
row has the same ``H`` and ``t``; the table has one row per unit. The other parameters are the
pick-and-place finger's (``U_L = 6``, ``U_sep = 1``, ``t_lim = 1``, ``E = 26``) and the profile
is ``P0 = 0.7 MPa`` ramped over 1 s, held ``hold`` s, released over 0.1 s; the horizon is
``t_after`` s after the release (an ``inf`` reset time means "longer than that").

Each map is one :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch` call (hold-time map:
one per hold time), so the rows run in parallel.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from ...model import status as st
from ...model.design import Design, DesignBatch
from .simulate import CLASS_NAMES, DEFAULT_METHOD, PressureProfile, reset_times_batch

__all__ = ["ResetMapSpec", "reset_time_maps"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ResetMapSpec:
    """What the reset-time maps sweep (lengths in mm, times in s, pressure in MPa).

    Attributes
    ----------
    n_units : int
        Units per finger (1: the unit cell).
    H_values, t_at_H : sequence of float, float
        Heights of the ``H`` map and its thickness.
    t_values, H_at_t : sequence of float, float
        Thicknesses of the ``t`` map and its height.
    hold_values, hold_H, hold_t : sequence of float, sequence of float, float
        Hold times of the ``hold`` map, the heights it is drawn for, and their thickness.
    P0, ramp, hold, release : float
        Pulse: pressure, ramp-up time, default hold time, release time.
    t_after : float
        Horizon after the release.
    U_L, U_sep, t_lim, E : float
        The other design parameters.
    method : str
        Integrator of :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch`.
    """

    n_units: int = 1
    H_values: Sequence[float] = field(
        default_factory=lambda: tuple(np.round(np.arange(2.50, 3.2001, 0.025), 4))
    )
    t_at_H: float = 0.8
    t_values: Sequence[float] = field(
        default_factory=lambda: tuple(np.round(np.arange(0.70, 1.0001, 0.0125), 4))
    )
    H_at_t: float = 3.0
    hold_values: Sequence[float] = field(
        default_factory=lambda: tuple(np.round(np.logspace(-2, 1, 16), 5))
    )
    hold_H: Sequence[float] = (2.8, 2.9, 3.0)
    hold_t: float = 0.8
    P0: float = 0.7
    ramp: float = 1.0
    hold: float = 4.0
    release: float = 0.1
    t_after: float = 30.0
    U_L: float = 6.0
    U_sep: float = 1.0
    t_lim: float = 1.0
    E: float = 26.0
    method: str = DEFAULT_METHOD

    def profile(self, hold: float | None = None) -> PressureProfile:
        """The pulse, with the default hold time or ``hold``."""
        hold = self.hold if hold is None else hold
        tau2 = self.ramp
        return PressureProfile.pulse(self.P0, (0.0, tau2, tau2 + hold, tau2 + hold + self.release))

    def design(self, H: float, t: float) -> Design:
        """A finger of ``n_units`` equal units of dome height ``H`` and thickness ``t``."""
        return Design(
            H=[H] * self.n_units, U_L=self.U_L, U_sep=self.U_sep, t=t, t_lim=self.t_lim, E=self.E
        )


def _rows(spec, name, designs, values, profile, extra) -> pd.DataFrame:
    """Reset times of ``designs`` under ``profile`` as table rows (one per unit)."""
    batch = DesignBatch.from_designs(designs)
    t_end = profile.t_release + spec.t_after
    out = reset_times_batch(batch, profile, t_end=t_end, method=spec.method)
    rows = []
    for i, design in enumerate(designs):
        for k in range(design.n_units):
            rows.append(
                {
                    "map": name,
                    "value": values[i],
                    "H": design.H[0],
                    "t": design.t,
                    "hold": extra["hold"],
                    "n_units": design.n_units,
                    "unit": k + 1,
                    "reset_time": out["reset_time"][i, k],
                    "snap_through": out["snap_through"][i, k],
                    "snap_back": out["snap_back"][i, k],
                    "unit_class": CLASS_NAMES[int(out["unit_class"][i, k])] or "never_inverted",
                    "status": st.Status(int(out["status"][i])).label,
                    "horizon": spec.t_after,
                    "P0": spec.P0,
                    "method": spec.method,
                }
            )
    return pd.DataFrame(rows)


def reset_time_maps(spec: ResetMapSpec | None = None, **changes) -> dict[str, pd.DataFrame]:
    """Compute the three maps; returns ``{"H": frame, "t": frame, "hold": frame}``.

    Parameters
    ----------
    spec : ResetMapSpec, optional
        Defaults as documented; ``changes`` override single fields.
    """
    spec = replace(spec or ResetMapSpec(), **changes)
    maps = {}
    H_values = [float(v) for v in spec.H_values]
    maps["H"] = _rows(
        spec,
        "H",
        [spec.design(H, spec.t_at_H) for H in H_values],
        H_values,
        spec.profile(),
        {"hold": spec.hold},
    )
    t_values = [float(v) for v in spec.t_values]
    maps["t"] = _rows(
        spec,
        "t",
        [spec.design(spec.H_at_t, t) for t in t_values],
        t_values,
        spec.profile(),
        {"hold": spec.hold},
    )
    frames = []
    designs = [spec.design(float(H), spec.hold_t) for H in spec.hold_H]
    for hold in spec.hold_values:
        frames.append(
            _rows(
                spec,
                "hold",
                designs,
                [float(hold)] * len(designs),
                spec.profile(float(hold)),
                {"hold": float(hold)},
            )
        )
    maps["hold"] = pd.concat(frames, ignore_index=True)
    for name, frame in maps.items():
        logger.info("reset map %s: %d rows", name, len(frame))
    return maps
