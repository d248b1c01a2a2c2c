"""Dynamics of the damped lattice under pressure: snap-through, snap-back and reset times.

The equations of motion are MODEL.md §8 (kernels in :mod:`dpfexplore._kernels.dynamics.motion`):
lumped masses, the paper's damping on every two-node spring, isotropic drag and pressure on
the chamber faces following the faces, driven by a piecewise-linear :class:`PressureProfile`.

Methods (``method=``)
---------------------
``"rodas4"`` (default)
    Full second-order model, Rodas4 Rosenbrock method on the analytic Jacobian
    (:mod:`dpfexplore._kernels.dynamics.rosenbrock`). Stiffly accurate and L-stable, so the
    ~1e-5 s velocity relaxation costs nothing; ~300 steps for the 15 s pick-and-place scene.
``"rodas4-overdamped"``
    Inertia dropped (``C(x) ẋ = F_ext - ∇E``) by the same kernel with zero mass (an index-1
    DAE for the velocities). The masses are so small that it differs from the full model by
    about 1e-5 relative in reset times; it is no faster, because Rodas4 already steps over
    the inertial time scale.
``"dopri5"``, ``"dopri5-overdamped"``
    Dormand–Prince 5(4) explicit pair (the paper's "Runge–Kutta") on either model; step sizes
    are bounded by stability (~1e-5 s full, ~1e-4 s overdamped), whatever the tolerance.
``"release"``
    The reduced model of :mod:`dpfexplore.solvers.dynamics.release`: the loading at a loose
    tolerance, a Newton jump to the loaded equilibrium at the end of the hold, the release at full
    tolerance (overdamped). Reset times only (``reset_times_batch``); single pulses with a long
    hold.
``"fast"``
    The fast reset-time model of :mod:`dpfexplore.solvers.dynamics.fast_reset`: the loading solved
    statically, the release integrated loosely, a fitted correction, a 90 % interval per unit
    and a fallback to ``"rodas4"`` where the model is not sure or not trained. Reset times only
    (``reset_times_batch``), for the scene its model was trained on.
``"radau"``
    SciPy's ``solve_ivp(method="Radau")`` on the same full equations with the analytic
    Jacobian (:mod:`dpfexplore.solvers.dynamics.scipy_baseline`): the trusted, slow reference.

Events and outputs
------------------
Each unit's threshold is its barrier ``u_barrier`` (``u = 3/4`` where ``α ≥ 1/9``, MODEL.md
§6). Crossings are located on the dense output, not at step ends. Snap-through is a unit's
first upward crossing, snap-back its last downward one; reset time, unit class and final state
follow :mod:`dpfexplore._kernels.dynamics.batch` (reset time measured from the profile's last
knot ``τ_end``; ``inf`` when still inverted at ``t_end``, with ``horizon = t_end - τ_end``).

Every run returns a status (:class:`dpfexplore.model.status.Status`); step and time caps make sure
none hangs.
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics import events as kev
from ..._kernels.dynamics import motion as kdyn
from ..._kernels.dynamics.batch import INTEGRATORS, RESET_TIMES_KERNELS, rest_state
from ..._kernels.records import (
    LatticeBatch,
    MotionModel,
    Physics,
    PressureKnots,
    ResetRows,
    RunRecord,
)
from ...model import status as st
from ...model.design import Design, DesignBatch
from ...model.pressure import PressureProfile
from ..lattice import LatticeParams, lattice_params
from .common import (
    CLASS_NAMES,
    DEFAULT_METHOD,
    METHODS,
    MethodInfo,
    SimulationResult,
    build_result,
    check_horizon,
    controls,
    empty_reset_columns,
    method_info,
    positive_number,
    run_reset_batch,
)
from .fast_reset import fast_reset_times_batch
from .release import release_reset_times_batch
from .reset_model import ResetModel
from .scipy_baseline import simulate_scipy

__all__ = [
    "CLASS_NAMES",
    "DEFAULT_METHOD",
    "METHODS",
    "MethodInfo",
    "PressureProfile",
    "SimulationResult",
    "empty_reset_columns",
    "reset_times_batch",
    "simulate",
]

logger = logging.getLogger(__name__)


def simulate(
    design: Design,
    profile: PressureProfile,
    *,
    t_end: float,
    t_start: float = 0.0,
    method: str = DEFAULT_METHOD,
    n_samples: int = 601,
    atol: float | None = None,
    rtol: float | None = None,
    h_max: float | None = None,
    max_steps: int | None = None,
    stop_when_reset: bool = False,
    event_capacity: int = 256,
    x0: NDArray | None = None,
    v0: NDArray | None = None,
    eta: float = kdyn.ETA_INTERNAL,
    eta_iso: float = kdyn.ETA_ISO,
    lattice: LatticeParams | None = None,
) -> SimulationResult:
    """Simulate a finger under a pressure profile, from rest (flat, unloaded) by default.

    Parameters
    ----------
    design : Design
    profile : PressureProfile
    t_end : float, s
        End of the run; at least ``profile.t_release``.
    t_start : float, s
        Start of the integration: the finger keeps its initial state (the samples before
        ``t_start`` hold it) and integration starts there. Exact when that state is at rest
        under zero pressure (the default start): the pressure must be 0 on ``[0, t_start)``
        (:meth:`PressureProfile.zero_until`).
        A leg section whose phase starts later is integrated only from its phase's start
        (:mod:`dpfexplore.solvers.legs.leg`). Not for ``method="radau"``.
    method : str
        See :data:`METHODS` (module docstring).
    n_samples : int
        Evenly spaced output samples on ``[0, t_end]`` (the decimated trajectory).
    atol, rtol : float, optional
        Position tolerances (mm, relative); defaults per method.
    h_max : float, optional, s
        Largest step.
    max_steps : int, optional
        Cap on step attempts; past it the run stops with ``Status.STEP_LIMIT``.
    stop_when_reset : bool
        Stop once past the profile with every inverted unit reset and no threshold crossing
        for ``SETTLE_TIME`` (1 s, :mod:`dpfexplore._kernels.dynamics.events`: a dome pushed back
        over its threshold by a neighbour's snap is still followed); the samples after that are
        NaN. Speeds up reset-time evaluation.
    event_capacity : int
        Crossings kept in ``events`` (all are counted).
    x0, v0 : ndarray of shape (4N - 2,), optional
        Initial free coordinates (mm) and velocities (mm/s) instead of the flat finger at
        rest (e.g. a stable state from :func:`dpfexplore.solvers.statics.find_state`). The
        overdamped models ignore ``v0``: their velocities follow from the positions.
    eta, eta_iso : float, N·s/mm
        Internal and isotropic damping (MODEL.md §8 values by default; 0 and 0 make the
        lattice conservative, which the tests use).
    lattice : LatticeParams, optional
        Kernel parameters to use instead of the design's own, for constructions the design
        parameters cannot express (e.g. ``lattice_params(design).scaled(COL_KT, 0.0)``: a dome
        with no torsional restraint, the isolated dome of MODEL.md §4). Same ``N`` as the
        design, which still labels the result.

    Returns
    -------
    SimulationResult
    """
    if not isinstance(design, Design):
        raise ValueError(f"design = {design!r}: must be a Design")
    t_end = check_horizon(t_end, profile)
    info = method_info(method)
    if n_samples < 0:
        raise ValueError(f"n_samples = {n_samples!r}: must be >= 0")
    t_start = _quiet_start(t_start, profile, t_end)
    if info.name == "radau":
        custom = {
            "x0": x0 is not None,
            "v0": v0 is not None,
            "lattice": lattice is not None,
            "t_start": t_start != 0.0,
            "eta": eta != kdyn.ETA_INTERNAL or eta_iso != kdyn.ETA_ISO,
        }
        if any(custom.values()):
            raise ValueError(
                f"method = 'radau': the SciPy baseline runs the standard scene only; drop "
                f"{', '.join(k for k, v in custom.items() if v)}"
            )

        return simulate_scipy(
            design, profile, t_end=t_end, n_samples=n_samples, atol=atol, rtol=rtol
        )
    if info.model in ("release", "fast"):
        raise ValueError(
            f"method = {info.name!r}: this model gives reset times only; use "
            f"reset_times_batch(..., method={info.name!r})"
        )
    params = lattice_params(design) if lattice is None else lattice
    n_units = design.n_units
    if params.n_units != n_units:
        raise ValueError(f"lattice: has {params.n_units} units, the design {n_units}")
    n = 4 * n_units - 2
    knot_t, knot_p = profile.knots()
    ctrl = controls(
        info,
        t_release=profile.t_release,
        atol=atol,
        rtol=rtol,
        h_max=h_max,
        max_steps=max_steps,
        stop_when_reset=stop_when_reset,
    )
    phys = np.array(
        [
            positive_number("eta", eta, allow_zero=True),
            positive_number("eta_iso", eta_iso, allow_zero=True),
            kdyn.node_mass(n_units),
        ]
    )
    if info.model == "overdamped":
        if eta == 0.0 and eta_iso == 0.0:
            raise ValueError("eta = eta_iso = 0: the overdamped model needs damping")
        phys[kdyn.PHYS_MASS] = 0.0
    y = np.empty(2 * n)
    rest_state(params.unit_params, params.h, y)
    for name, value, part in (("x0", x0, slice(0, n)), ("v0", v0, slice(n, 2 * n))):
        if value is not None:
            value = np.asarray(value, dtype=float)
            if value.shape != (n,) or not np.all(np.isfinite(value)):
                raise ValueError(
                    f"{name}: need {n} finite values (4N - 2), got shape {value.shape}"
                )
            y[part] = value
    t_out = np.linspace(0.0, t_end, n_samples) if n_samples else np.empty(0)
    x_out = np.full((n_samples, n), np.nan)
    rec = np.empty((n_units, kev.N_REC))
    log = np.zeros((event_capacity, 3))
    stats = np.zeros(kev.N_STATS, dtype=np.int64)
    code = INTEGRATORS[info.integrator](
        y,
        t_start,
        t_end,
        MotionModel(params.unit_params, params.h, knot_t, knot_p, phys),
        ctrl,
        RunRecord(t_out, x_out, rec, log, stats),
    )
    status = st.Status(code)
    if status != st.OK:
        logger.warning("simulate(%s, method=%s): %s", design.name or "design", method, status.label)
    return build_result(
        design,
        profile,
        info.name,
        status,
        params,
        t_out,
        x_out,
        rec,
        log,
        stats,
        y[:n].copy(),
        y[n:].copy(),
        t_end,
    )


def _quiet_start(t_start, profile: PressureProfile, t_end: float) -> float:
    """``t_start`` as a float; ``ValueError`` unless in ``[0, t_end]`` with no pressure before."""
    t_start = float(t_start)
    if not math.isfinite(t_start) or t_start < 0.0 or t_start > t_end:
        raise ValueError(f"t_start = {t_start!r}: must be a time in [0, t_end = {t_end}] s")
    if t_start > 0.0 and t_start > profile.zero_until():
        raise ValueError(
            f"t_start = {t_start} s: the pressure is not 0 before it (it rises after "
            f"{profile.zero_until()} s); the finger would not stay at rest"
        )
    return t_start


def reset_times_batch(
    batch: DesignBatch,
    profile: PressureProfile,
    *,
    t_end: float,
    method: str = DEFAULT_METHOD,
    atol: float | None = None,
    max_steps: int | None = None,
    max_rel_halfwidth: float | None = None,
    model: ResetModel | str | None = None,
) -> dict[str, NDArray]:
    """Reset times of many designs under one profile, evaluated in parallel.

    Rows run in a Numba ``prange`` loop (the method's kernel of
    :data:`dpfexplore._kernels.dynamics.batch.RESET_TIMES_KERNELS`): everything per row is
    compiled, ``nogil`` code, so there is nothing for Python threads to add, and the parallel
    region is one call with no per-row dispatch. Rows differ in cost by 10x or more (bistable
    designs run to the horizon, metastable ones stop when they reset), so the chunk size is set
    to 1 for the call: threads take rows as they free up instead of a fixed half each. Each run
    stops as soon as every inverted unit has reset after the profile ends.

    Parameters
    ----------
    batch : DesignBatch
    profile : PressureProfile
    t_end : float, s
        Horizon of every run.
    method : str
        Any Numba method of :data:`METHODS` (``"rodas4"`` by default), ``"release"`` or
        ``"fast"``.
    atol : float, optional, mm
    max_steps : int, optional
    max_rel_halfwidth : float, optional
        ``"fast"`` only: largest relative half-width of a metastable unit's 90 % interval the
        caller accepts; designs with a wider one run ``"rodas4"`` instead.
    model : ResetModel or path, optional
        ``"fast"`` only: the fitted model (default: the packaged one).

    Returns
    -------
    dict
        ``"status"`` (int8, (n,)), ``"final_state"`` (int64 (n,), unit 1 = most significant
        bit; -1 for invalid rows), ``"reset_time"``, ``"snap_through"``, ``"snap_back"``
        (float64 (n, 12), s; NaN for padding, invalid rows, units never inverted and
        no-contact units; reset ``inf`` if never reset within the horizon), ``"unit_class"``
        (int8 (n, 12): 0 bistable, 1 metastable, 2 monostable, 3 no contact (reach ``d``
        clamped, MODEL.md §3: no inversion in this model), -1 never inverted or padding).
        Invalid designs (``batch.status() != OK``) keep their status and NaN outputs.
        ``"fast"`` adds ``"reset_time_lo"``, ``"reset_time_hi"`` (the 90 % interval),
        ``"fallback"`` (bool (n,): the row ran ``"rodas4"``) and ``"fallback_reason"`` (int16
        bit flags, :data:`dpfexplore.solvers.dynamics.fast_reset.FALLBACK_REASONS`); its
        snap-through times are NaN.
    """
    if not isinstance(batch, DesignBatch):
        raise ValueError(f"batch = {batch!r}: must be a DesignBatch")
    t_end = check_horizon(t_end, profile)
    info = method_info(method)
    if info.model != "fast" and (max_rel_halfwidth is not None or model is not None):
        raise ValueError(f"method = {method!r}: max_rel_halfwidth and model are for 'fast'")
    if info.model == "fast":
        if atol is not None or max_steps is not None:
            raise ValueError(
                "method = 'fast': its tolerances are the model's; drop atol, max_steps"
            )
        full = functools.partial(reset_times_batch, method=DEFAULT_METHOD)
        return fast_reset_times_batch(
            batch,
            profile,
            t_end=t_end,
            full_model=full,
            max_rel_halfwidth=max_rel_halfwidth,
            model=model,
        )
    if info.model == "release":
        return release_reset_times_batch(batch, profile, t_end=t_end, atol=atol)
    if info.integrator < 0:
        raise ValueError(f"method = {method!r}: not available for batches; use a Numba method")

    def launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out):
        mass = 0.0 if info.model == "overdamped" else kdyn.MASS_PER_UNIT
        RESET_TIMES_KERNELS[info.integrator](
            LatticeBatch(unit_params, h, n_units),
            valid,
            PressureKnots(knot_t, knot_p),
            Physics(kdyn.ETA_INTERNAL, kdyn.ETA_ISO, mass),
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

    return run_reset_batch(batch, profile, info, atol, max_steps, launch)
