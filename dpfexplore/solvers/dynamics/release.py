"""Reduced models of the reset time, with their errors against the full lattice.

The release model (``method="release"``)
    :mod:`dpfexplore._kernels.reduced`: the loading integrated at a loose tolerance (it only
    has to get the inversion pattern right), the state at the start of the release replaced by
    the loaded equilibrium that Newton reaches from it (the end of a long hold), the release
    integrated at the requested tolerance (overdamped Rodas4). It keeps every coordinate of the
    lattice (see below why fewer do not work); the reduction is in time. Measured by
    ``dpfexplore bench dynamics`` (100 random metastable designs): the same final states and
    classes as the full model, reset-time errors like the full model's at the same tolerance,
    about 30 % less time. It needs a single pulse whose hold is long against the finger's
    slowest relaxation; its snap-through times come from the loose loading (~1e-3 s).

Why not one coordinate per metastable unit
    The suggested reduction (each dome's extension as a coordinate, the rest of the finger
    condensed statically into a restoring stiffness and a damping, ``C_q q̇ = -f(q) - K_q q``)
    was built and measured on the pick-and-place finger: the condensed statics are right (the
    bistable units' unloaded extensions to 1e-4), but the reset times come out 0.84 s and 0.45 s
    against 2.66 s and 1.61 s. The lattice with the dome lengths held fixed is not stiff: each
    unit's four-bar quadrilateral (dome, two posts, layer) shears against the torsional springs
    alone (``k_t/h² ≈ 0.15 N/mm`` against ``k_b ≈ 10 N/mm``), damped by the drag, with rates of
    1.2-6 /s, as slow as the creep itself. Static condensation assumes those modes are
    instantaneous; adding them as modal coordinates (Craig–Bampton, 8 coordinates) still left
    4-18 % errors from the linearised geometry of a finger that curls through tens of degrees.
    Only the full, geometrically non-linear lattice reaches the 0.1 % level, so the reduction
    that pays is in time (a loose loading, a jump over the hold), not in coordinates.
"""

from __future__ import annotations

from numpy.typing import NDArray

from ..._kernels import dynamics as kdyn
from ..._kernels.reduced import release_batch
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
            unit_params,
            h,
            n_units,
            valid,
            knot_t,
            knot_p,
            kdyn.ETA_INTERNAL,
            kdyn.ETA_ISO,
            ctrl,
            t_end,
            codes,
            out["final_state"],
            out["reset_time"],
            out["snap_through"],
            out["snap_back"],
            out["unit_class"],
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
