"""Reduced models of the reset time, with their errors against the full lattice.

The release model (``method="release"``)
    :mod:`dpfexplore._kernels.reset.reduced`: the loading integrated at a loose tolerance (it only
    has to get the inversion pattern right), the state at the start of the release replaced by
    the loaded equilibrium that Newton reaches from it (the end of a long hold), the release
    integrated at the requested tolerance (overdamped Rodas4). It keeps every coordinate of the
    lattice (see below why fewer do not work); the reduction is in time. Its errors and cost
    against the full model are measured by ``dpfexplore bench dynamics`` (the benchmarks page).
    It needs a single pulse whose hold is long against the finger's slowest relaxation; its
    snap-through times come from the loose loading (~1e-3 s).

Why not one coordinate per metastable unit
    A reduction to each dome's extension, the rest condensed statically, misses the reset
    times by a factor of about 3: the finger's shear modes are as slow as the creep itself.
    Only the full, geometrically non-linear lattice reaches the 0.1 % level, so the reduction
    that pays is in time (a loose loading, a jump over the hold), not in coordinates
    (docs/decisions.md, "Reduced reset models", has the measurements).
"""

from __future__ import annotations

from numpy.typing import NDArray

from ..._kernels.dynamics import motion as kdyn
from ..._kernels.records import LatticeBatch, Physics, PressureKnots, ResetRows
from ..._kernels.reset.reduced import release_batch
from ...model.design import Design, DesignBatch
from .common import METHODS, check_horizon, run_reset_batch

__all__ = ["release_reset_times", "release_reset_times_batch"]


def _single_pulse(profile) -> None:
    if (
        len(profile.times) != 4
        or profile.pressures[0] != 0.0
        or profile.pressures[3] != 0.0
        or profile.pressures[1] != profile.pressures[2]
    ):
        raise ValueError(
            f"profile = {profile!r}: the release model needs one pulse (0, P0, P0, 0) at "
            "(tau1, tau2, tau3, tau4)"
        )


def release_reset_times_batch(
    batch: DesignBatch, profile, *, t_end: float, atol: float | None = None
) -> dict[str, NDArray]:
    """Reset times of the release model for a batch.

    Same contract as :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch`; the
    snap-through times come from the loose loading phase (~1e-3 s).
    """
    _single_pulse(profile)
    t_end = check_horizon(t_end, profile)

    def launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out):
        release_batch(
            LatticeBatch(unit_params, h, n_units),
            valid,
            PressureKnots(knot_t, knot_p),
            Physics(kdyn.ETA_INTERNAL, kdyn.ETA_ISO, 0.0),
            ctrl,
            t_end,
            ResetRows(
                codes,
                out["final_state"],
                out["reset_time"],
                out["snap_through"],
                out["snap_back"],
                out["unit_class"],
            ),
        )

    return run_reset_batch(batch, profile, METHODS["release"], atol, None, launch)


def release_reset_times(
    design: Design, profile, *, t_end: float, atol: float | None = None
) -> dict[str, NDArray]:
    """The release model for one design: the batch contract's arrays for a single row."""
    out = release_reset_times_batch(
        DesignBatch.from_designs([design]), profile, t_end=t_end, atol=atol
    )
    n_units = design.n_units
    return {key: value[0, :n_units] if value.ndim == 2 else value[0] for key, value in out.items()}
