"""The fast reset-time model: physics for the release, a fitted correction, an interval, a fallback.

``reset_times_batch(..., method="fast")`` (:mod:`.dynamics`) runs this. Per design:

1. **Core** (:mod:`dpfexplore._kernels.reset.fast_reset`): the loading is not integrated. Which
   domes snap through and the loaded equilibrium at the end of the hold come from statics
   (:mod:`dpfexplore._kernels.reset.loaded_state`); the release ramp and the creep after it are
   integrated (overdamped Rodas3 at a loose tolerance), stopping once no crossing can follow.
   Why the release is integrated at all: after the pressure goes, the finger uncurls along its
   slowest mode (~1 /s) and that motion carries each metastable dome to the fold where its
   inverted equilibrium disappears; the reset time is that sweep plus the passage near the
   fold, and neither static quantities nor a fit on them predicted it (``reset-model report``
   records the ablation: a fit on statics features left ~15 % median error).
2. **Correction**: regression trees on :data:`.fast_reset_model.FEATURES` (the core's time and
   diagnostics, the unit's geometry) predict ``log(T_full / T_core)``; the corrected time is
   ``T_core·exp(correction)``.
3. **Interval**: a second tree ensemble predicts the 90 % quantile ``s`` of the remaining
   error; split conformal calibration on held-out designs gives the factor ``q`` so that
   ``T·exp(±q·s)`` covers the full model's time for 90 % of units (for monostable units, whose
   times are milliseconds or negative, a fixed absolute half-width instead).
4. **Fallback** to the full model (``rodas4``) for a design that is outside the trained domain or
   scene, whose core failed, whose snap pattern was decided by less than ``margin_min``, with a
   unit whose interval straddles the horizon (resets or not is undecided), whose release run
   saw a dome cross its threshold more than once (:func:`raced_release`), or with an interval
   wider than the caller's ``max_rel_halfwidth``. Those rows carry the full model's values and
   a zero-width interval, and are flagged with the reason.

Snap-through times are not computed by the core (NaN in fast rows); snap-back times are.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics import motion as kdyn
from ..._kernels.dynamics.events import CTRL_H_INIT, CTRL_H_MAX
from ..._kernels.layout import COL_ALPHA
from ..._kernels.records import FastResetRows, LatticeBatch, Physics, PressureKnots
from ..._kernels.reset.fast_reset import (
    DD_LOAD_MARGIN,
    DD_STEPS,
    N_DESIGN_DIAG,
    N_UNIT_DIAG,
    UD_CROSSINGS,
    UD_MARGIN,
    UD_RELEASE,
    UD_U_LOAD,
    fast_reset_batch,
)
from ..._kernels.reset.release import UD_EVENT_ERROR, UD_EVENT_STEP
from ...model import status as st
from ...model.design import DesignBatch
from ...model.domain import MAX_UNITS
from ...model.pressure import PressureProfile
from ..lattice import pack_batch
from .common import (
    CLASS_BISTABLE,
    CLASS_METASTABLE,
    CLASS_MONOSTABLE,
    CLASS_NEVER_INVERTED,
    METHODS,
    controls,
    mark_no_contact,
    unit_no_contact,
)
from .reset_model import FEATURES, ResetModel, load_reset_model

__all__ = [
    "FALLBACK_CORE",
    "FALLBACK_DOMAIN",
    "FALLBACK_HORIZON",
    "FALLBACK_LOADING",
    "FALLBACK_RACE",
    "FALLBACK_REASONS",
    "FALLBACK_SCENE",
    "FALLBACK_WIDTH",
    "compile_fast_reset",
    "fast_reset_core",
    "fast_reset_times_batch",
    "raced_release",
    "unit_features",
]

#: Fallback reasons (bit flags of ``fallback_reason``).
FALLBACK_DOMAIN = 1
FALLBACK_SCENE = 2
FALLBACK_CORE = 4
FALLBACK_LOADING = 8
FALLBACK_HORIZON = 16
FALLBACK_WIDTH = 32
FALLBACK_RACE = 64
FALLBACK_REASONS = {
    FALLBACK_DOMAIN: "design outside the trained domain",
    FALLBACK_SCENE: "profile or horizon outside the trained scene",
    FALLBACK_CORE: "the physical core failed",
    FALLBACK_LOADING: "snap pattern decided too narrowly",
    FALLBACK_HORIZON: "a unit may or may not reset within the horizon",
    FALLBACK_WIDTH: "interval wider than asked",
    FALLBACK_RACE: "a dome crossed its threshold again during the release (a race of resets)",
}

#: The core integrates this fraction of the horizon beyond it, so that a unit resetting just
#: after the horizon is seen (its interval then decides whether the row falls back).
HORIZON_SLACK = 0.1
#: First step (s) and largest step (s) of the core's release integration.
CORE_H_INIT = 0.02
CORE_H_MAX = 5.0
#: Step cap of the core's release integration.
CORE_MAX_STEPS = 20_000
#: Shortest reset time (s) of a metastable unit (MODEL.md §8).
METASTABLE_MIN_RESET = 0.05
#: The log of the core time is floored at this (s) for the features.
LOG_T_FLOOR = 1e-3
#: Tolerance (relative) on the scene's knots.
SCENE_RTOL = 1e-9


def _single_pulse(profile: PressureProfile) -> tuple[float, tuple[float, ...]] | None:
    times, pressures = profile.times, profile.pressures
    if (
        len(times) != 4
        or pressures[0] != 0.0
        or pressures[3] != 0.0
        or pressures[1] != pressures[2]
        or pressures[1] <= 0.0
    ):
        return None
    return pressures[1], tuple(times)


def fast_reset_core(
    batch: DesignBatch,
    profile: PressureProfile,
    *,
    t_end: float,
    atol: float,
    rows: NDArray | None = None,
    status: NDArray | None = None,
) -> dict[str, NDArray]:
    """The physical core (no fit) on the valid rows of a batch (``rows``: a subset of those).

    Parameters
    ----------
    batch : DesignBatch
    profile : PressureProfile
        A single pulse ``(0, P0, P0, 0)`` at ``(τ1..τ4)``.
    t_end : float, s
    atol : float, mm
        Position tolerance of the release integration.
    rows : ndarray of int, optional
        Rows to run (default: every valid row).
    status : ndarray of int8, optional
        ``batch.status()``, if the caller has it already.

    Returns
    -------
    dict
        The columns of ``reset_times_batch`` (``snap_through`` NaN) plus ``"unit_diag"``
        (n, MAX_UNITS, N_UNIT_DIAG), ``"design_diag"`` (n, N_DESIGN_DIAG), NaN where not run,
        and ``"alpha"`` (n, MAX_UNITS), each unit's dome energy ratio (NaN past ``N``).
    """
    pulse = _single_pulse(profile)
    if pulse is None:
        raise ValueError(f"profile = {profile!r}: the fast model needs one pulse (0, P0, P0, 0)")
    out = _empty_core(batch, status)
    valid = out["status"] == st.OK
    if rows is not None:
        chosen = np.zeros(len(batch), dtype=bool)
        chosen[rows] = True
        valid &= chosen
    if not valid.any():
        return out
    unit_params, h, n_units = pack_batch(batch)
    out["alpha"] = unit_params[:, :, COL_ALPHA].copy()
    knot_t, knot_p = profile.knots()
    ctrl = controls(
        METHODS["rodas4-overdamped"],
        t_release=profile.t_release,
        atol=atol,
        rtol=None,
        h_max=CORE_H_MAX,
        max_steps=CORE_MAX_STEPS,
        stop_when_reset=True,
    )
    ctrl[CTRL_H_INIT] = CORE_H_INIT
    ctrl[CTRL_H_MAX] = CORE_H_MAX
    codes = np.zeros(len(batch), dtype=np.int64)
    previous = numba.set_parallel_chunksize(1)  # rows differ in cost by 10x or more
    try:
        fast_reset_batch(
            LatticeBatch(unit_params, h, n_units),
            valid,
            PressureKnots(knot_t, knot_p),
            Physics(kdyn.ETA_INTERNAL, kdyn.ETA_ISO, 0.0),
            ctrl,
            float(t_end),
            FastResetRows(
                codes,
                out["final_state"],
                out["reset_time"],
                out["snap_back"],
                out["unit_class"],
                out["unit_diag"],
                out["design_diag"],
            ),
        )
    finally:
        numba.set_parallel_chunksize(previous)
    out["status"][valid] = codes[valid].astype(np.int8)
    # No inversion without dome contact (MODEL.md §3): as in the full model, so that core and
    # reference agree on what a reset is when the correction is trained.
    mark_no_contact(
        _no_contact(batch) & valid[:, None],
        batch.n_units,
        out["final_state"],
        out["reset_time"],
        out["snap_through"],
        out["snap_back"],
        out["unit_class"],
    )
    return out


def _no_contact(batch: DesignBatch) -> NDArray[np.bool_]:
    """Units whose reach ``d`` is clamped, shape (n, MAX_UNITS) (False on padding)."""
    return unit_no_contact(batch)


def unit_features(
    batch: DesignBatch, core: dict[str, NDArray], units: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """The :data:`FEATURES` rows of the units where ``units`` (shape ``(n, MAX_UNITS)``) is True.

    Rows are in C order of ``np.nonzero(units)``.
    """
    design, unit = np.nonzero(units)
    n_units = batch.n_units[design]
    alpha = np.where(np.arange(MAX_UNITS)[None, :] < batch.n_units[:, None], core["alpha"], 0.0)
    padded = np.pad(alpha, ((0, 0), (1, 1)))  # α of the neighbours, 0 beyond the ends
    ud = core["unit_diag"][design, unit]
    dd = core["design_diag"][design]
    reset = core["reset_time"]
    inverted = np.isfinite(reset) | np.isinf(reset)
    t_core = reset[design, unit]
    columns = {
        "log_T_core": np.log(np.maximum(t_core, LOG_T_FLOOR)),
        "n_units": n_units,
        "unit_from_base": unit,
        "unit_from_tip": n_units - 1 - unit,
        "alpha": alpha[design, unit],
        "H": batch.H[design, unit],
        "t": batch.t[design],
        "t_lim": batch.t_lim[design],
        "U_L": batch.U_L[design, unit],
        "U_sep": batch.U_sep[design, unit],
        "alpha_before": padded[design, unit],
        "alpha_after": padded[design, unit + 2],
        "u_load": ud[:, UD_U_LOAD],
        "load_margin": ud[:, UD_MARGIN],
        "crossings": ud[:, UD_CROSSINGS],
        "log_event_step": np.log(np.nan_to_num(ud[:, UD_RELEASE + UD_EVENT_STEP], nan=1e-6)),
        "event_error": np.nan_to_num(ud[:, UD_RELEASE + UD_EVENT_ERROR], nan=0.0),
        "n_inverted": inverted.sum(axis=1)[design],
        "n_reset_core": np.isfinite(reset).sum(axis=1)[design],
        "release_steps": dd[:, DD_STEPS],
        "design_load_margin": dd[:, DD_LOAD_MARGIN],
    }
    return np.column_stack([np.asarray(columns[name], dtype=float) for name in FEATURES])


def in_domain(model: ResetModel, batch: DesignBatch) -> NDArray[np.bool_]:
    """Rows inside the model's trained design domain (every unit's values in its ranges)."""
    dom = model.domain
    ok = (batch.n_units >= dom["n_units"][0]) & (batch.n_units <= dom["n_units"][1])
    active = np.arange(MAX_UNITS)[None, :] < batch.n_units[:, None]
    for name in ("H", "U_L", "U_sep"):
        low, high = dom[name]
        values = getattr(batch, name)
        with np.errstate(invalid="ignore"):
            inside = (values >= low) & (values <= high)
        ok &= np.all(inside | ~active, axis=1)
    for name in ("t", "t_lim"):
        low, high = dom[name]
        ok &= (getattr(batch, name) >= low) & (getattr(batch, name) <= high)
    for name, value in dom["fixed"].items():
        ok &= np.isclose(getattr(batch, name), value, rtol=SCENE_RTOL, atol=0.0)
    return ok


def in_scene(model: ResetModel, profile: PressureProfile, t_end: float) -> bool:
    """Whether the profile is the model's pulse and the horizon within what it was trained on."""
    pulse = _single_pulse(profile)
    if pulse is None:
        return False
    P0, tau = pulse
    same = math.isclose(P0, model.P0, rel_tol=SCENE_RTOL) and all(
        math.isclose(a, b, rel_tol=SCENE_RTOL, abs_tol=SCENE_RTOL)
        for a, b in zip(tau, model.tau, strict=True)
    )
    return same and 0.0 < t_end - tau[3] <= model.horizon_max * (1.0 + SCENE_RTOL)


def fast_reset_times_batch(
    batch: DesignBatch,
    profile: PressureProfile,
    *,
    t_end: float,
    full_model: Callable[..., dict[str, NDArray]],
    max_rel_halfwidth: float | None = None,
    model: ResetModel | str | None = None,
) -> dict[str, NDArray]:
    """Reset times by the fast model, with 90 % intervals and the fallback (module docstring).

    Parameters
    ----------
    batch : DesignBatch
    profile : PressureProfile
    t_end : float, s
        Horizon of the scene (absolute time), as for the full model.
    full_model : callable
        ``full_model(batch, profile, t_end=...)`` with the ``reset_times_batch`` contract: the
        fallback (``reset_times_batch`` with ``method="rodas4"`` from :mod:`.dynamics`).
    max_rel_halfwidth : float, optional
        Largest relative half-width of a metastable unit's interval the caller accepts; rows
        with a wider one run the full model. None: no limit.
    model : ResetModel or path, optional
        Default: the packaged model.

    Returns
    -------
    dict
        The ``reset_times_batch`` columns (``snap_through`` NaN in fast rows) plus
        ``"reset_time_lo"``, ``"reset_time_hi"`` (float64 (n, MAX_UNITS), s: the 90 % interval;
        equal to ``reset_time`` in fallback rows), ``"fallback"`` (bool (n,)) and
        ``"fallback_reason"`` (int16 (n,), bit flags ``FALLBACK_*``).

    Raises
    ------
    ValueError
        For a batch of another constants set than the model was trained on (naming both),
        or a bad ``max_rel_halfwidth``.
    """
    if not isinstance(model, ResetModel):
        model = load_reset_model(model)
    model.check_constants(batch.constants)
    if max_rel_halfwidth is not None:
        max_rel_halfwidth = float(max_rel_halfwidth)
        if not max_rel_halfwidth > 0.0:
            raise ValueError(f"max_rel_halfwidth = {max_rel_halfwidth!r}: must be > 0")
    n = len(batch)
    status = batch.status()
    valid = status == st.OK
    reason = np.zeros(n, dtype=np.int16)
    reason[valid & ~in_domain(model, batch)] |= FALLBACK_DOMAIN
    scene_ok = in_scene(model, profile, t_end)
    if not scene_ok:
        reason[valid] |= FALLBACK_SCENE
    fast = valid & (reason == 0)
    horizon = t_end - profile.t_release
    if fast.any():
        core = fast_reset_core(
            batch,
            profile,
            t_end=profile.t_release + horizon * (1.0 + HORIZON_SLACK),
            atol=model.atol,
            rows=np.flatnonzero(fast),
            status=status,
        )
    else:
        core = _empty_core(batch, status)
    out = {
        key: core[key]
        for key in (
            "status",
            "final_state",
            "reset_time",
            "snap_through",
            "snap_back",
            "unit_class",
        )
    }
    reason[fast & (core["status"] != st.OK)] |= FALLBACK_CORE
    reason[fast & ~(core["design_diag"][:, DD_LOAD_MARGIN] >= model.margin_min)] |= FALLBACK_LOADING
    reason[fast & raced_release(core)] |= FALLBACK_RACE
    fast &= reason == 0
    lo, hi, width = _predict(model, batch, core, fast, out)
    # resets or not within the horizon: decided only when the interval is on one side of it
    reset = out["reset_time"]
    with np.errstate(invalid="ignore"):
        straddles = (lo <= horizon) & (hi > horizon)
        beyond = lo > horizon
    reason[fast & straddles.any(axis=1)] |= FALLBACK_HORIZON
    reset[beyond] = np.inf
    lo[beyond] = np.inf
    hi[beyond] = np.inf
    if max_rel_halfwidth is not None:
        reason[fast & (np.nan_to_num(width, nan=0.0) > max_rel_halfwidth).any(axis=1)] |= (
            FALLBACK_WIDTH
        )
    fast &= reason == 0
    _summarise(out, batch, fast)
    # Units with a clamped reach have no inversion in this model (MODEL.md §3): the same class
    # as the full model gives them (fallback rows get it from the full model itself).
    no_contact = _no_contact(batch) & fast[:, None]
    mark_no_contact(
        no_contact,
        batch.n_units,
        out["final_state"],
        out["reset_time"],
        out["snap_through"],
        out["snap_back"],
        out["unit_class"],
    )
    lo[no_contact] = hi[no_contact] = np.nan
    # The snap-back time is the corrected reset time after the release, as in the full model
    # (t_release + reset_time); the core's own crossing time is the uncorrected estimate.
    resets = fast[:, None] & np.isfinite(reset)
    out["snap_back"][resets] = profile.t_release + reset[resets]
    out["reset_time_lo"] = np.where(fast[:, None], lo, out["reset_time"])
    out["reset_time_hi"] = np.where(fast[:, None], hi, out["reset_time"])
    fallback = valid & ~fast
    if fallback.any():
        rows = np.flatnonzero(fallback)
        full = full_model(batch.take(rows), profile, t_end=t_end)
        for key in (
            "status",
            "final_state",
            "reset_time",
            "snap_through",
            "snap_back",
            "unit_class",
        ):
            out[key][rows] = full[key]
        out["reset_time_lo"][rows] = full["reset_time"]
        out["reset_time_hi"][rows] = full["reset_time"]
    out["fallback"] = fallback
    out["fallback_reason"] = reason
    return out


def raced_release(core: dict[str, NDArray]) -> NDArray[np.bool_]:
    """Rows whose release run saw a unit cross its threshold more than once, (n,) bool.

    A dome that crosses down while a neighbour snaps back can be pushed over its threshold
    again; whether it is decides which unit resets first, a race that the core's loose position
    tolerance (``ResetModel.atol``) does not resolve: on 1000 random metastable designs every
    unit off by more than 5 % (one, by 67 %) was in such a row (~7 % of rows). The full model
    decides them; the training leaves them out for the same reason.
    """
    with np.errstate(invalid="ignore"):
        return (core["unit_diag"][:, :, UD_CROSSINGS] > 1.0).any(axis=1)


def _empty_core(batch: DesignBatch, status: NDArray | None) -> dict[str, NDArray]:
    """The core's columns before anything ran (the ``reset_times_batch`` contract's and more)."""
    n = len(batch)
    out = {
        "status": (batch.status() if status is None else status).astype(np.int8),
        "final_state": np.full(n, -1, dtype=np.int64),
        "reset_time": np.full((n, MAX_UNITS), np.nan),
        "snap_through": np.full((n, MAX_UNITS), np.nan),
        "snap_back": np.full((n, MAX_UNITS), np.nan),
        "unit_class": np.full((n, MAX_UNITS), CLASS_NEVER_INVERTED, dtype=np.int8),
        "unit_diag": np.full((n, MAX_UNITS, N_UNIT_DIAG), np.nan),
        "design_diag": np.full((n, N_DESIGN_DIAG), np.nan),
        "alpha": np.full((n, MAX_UNITS), np.nan),
    }
    return out


def _predict(
    model: ResetModel,
    batch: DesignBatch,
    core: dict[str, NDArray],
    fast: NDArray[np.bool_],
    out: dict[str, NDArray],
):
    """Correct the core's times of the ``fast`` rows in ``out``; return the interval.

    Returns ``lo``, ``hi`` (s) and the relative half-width of metastable units (NaN elsewhere),
    each of shape (n, MAX_UNITS).
    """
    reset = out["reset_time"]
    lo = reset.copy()
    hi = reset.copy()
    width = np.full(reset.shape, np.nan)
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(reset) & fast[:, None]
        slow = finite & (reset >= model.small_T)
        quick = finite & ~slow
    if slow.any():
        x = unit_features(batch, core, slow)
        corrected = reset[slow] * np.exp(model.correction.predict(x))
        half = model.conformal_q * np.maximum(model.scale.predict(x), model.scale_floor)
        reset[slow] = corrected
        lo[slow] = corrected * np.exp(-half)
        hi[slow] = corrected * np.exp(half)
        width[slow] = np.expm1(half)
    lo[quick] = reset[quick] - model.abs_halfwidth
    hi[quick] = reset[quick] + model.abs_halfwidth
    return lo, hi, width


def _summarise(out: dict[str, NDArray], batch: DesignBatch, fast: NDArray[np.bool_]) -> None:
    """Classes and final states of the ``fast`` rows from their (corrected) reset times."""
    reset = out["reset_time"][fast]
    active = np.arange(MAX_UNITS)[None, :] < batch.n_units[fast][:, None]
    with np.errstate(invalid="ignore"):
        cls = np.where(
            np.isnan(reset),
            CLASS_NEVER_INVERTED,
            np.where(
                np.isinf(reset),
                CLASS_BISTABLE,
                np.where(reset >= METASTABLE_MIN_RESET, CLASS_METASTABLE, CLASS_MONOSTABLE),
            ),
        )
    out["unit_class"][fast] = np.where(active, cls, CLASS_NEVER_INVERTED).astype(np.int8)
    # unit 1 is the most significant bit: bit k of unit k+1 has weight 2^(N-1-k)
    weights = np.where(
        active, 2.0 ** (batch.n_units[fast][:, None] - 1 - np.arange(MAX_UNITS)), 0.0
    )
    out["final_state"][fast] = (np.isinf(reset) * weights).sum(axis=1).astype(np.int64)


def compile_fast_reset() -> None:
    """Compile (or load from Numba's cache) the kernels of the fast model, on a tiny design."""
    from ...model.design import Design

    batch = DesignBatch.from_designs([Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)])
    core = fast_reset_core(
        batch, PressureProfile.pulse(0.7, (0.0, 0.01, 0.02, 0.03)), t_end=0.05, atol=1e-2
    )
    unit_features(batch, core, np.isfinite(core["reset_time"]))
    load_reset_model().correction.predict(np.zeros((1, len(FEATURES))))
