"""Dynamics of the damped lattice under pressure: snap-through, snap-back and reset times.

The equations of motion are MODEL.md §8 (kernels in :mod:`dpfexplore._kernels.dynamics`):
lumped masses, the paper's damping on every two-node spring, isotropic drag and pressure on
the chamber faces following the faces, driven by a piecewise-linear :class:`PressureProfile`.

Methods (``method=``)
---------------------
``"rodas4"`` (default)
    Full second-order model, Rodas4 Rosenbrock method on the analytic Jacobian
    (:mod:`dpfexplore._kernels.integrators_rosenbrock`). Stiffly accurate and L-stable, so the
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
    The reduced model of :mod:`dpfexplore.reduced`: the loading at a loose tolerance, a Newton
    jump to the loaded equilibrium at the end of the hold, the release at full tolerance
    (overdamped). Reset times only (``reset_times_batch``); single pulses with a long hold.
``"radau"``
    SciPy's ``solve_ivp(method="Radau")`` on the same full equations with the analytic
    Jacobian (:mod:`dpfexplore.dynamics_scipy`): the trusted, slow reference.

Events and outputs
------------------
Each unit's threshold is its barrier ``u_barrier`` (``u = 3/4`` where ``α ≥ 1/9``, MODEL.md
§6). Crossings are located on the dense output, not at step ends. Snap-through is a unit's
first upward crossing, snap-back its last downward one; reset time, unit class and final state
follow :mod:`dpfexplore._kernels.dynamics_batch` (reset time measured from the profile's last
knot ``τ_end``; ``inf`` when still inverted at ``t_end``, with ``horizon = t_end - τ_end``).

Every run returns a status (:class:`dpfexplore.status.Status`); step and time caps make sure
none hangs.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from . import status as st
from ._kernels import dynamics as kdyn
from ._kernels import events as kev
from ._kernels.dynamics_batch import (
    CLASS_BISTABLE,
    CLASS_METASTABLE,
    CLASS_MONOSTABLE,
    CLASS_NEVER_INVERTED,
    INTEGRATOR_DOPRI5,
    INTEGRATOR_RODAS4,
    integrate,
    reset_times_kernel,
    rest_state,
    summarise_units,
)
from ._kernels.lattice import dome_extensions, unpack_nodes
from ._kernels.layout import MAX_UNITS
from .design import Design, DesignBatch
from .lattice import LatticeParams, lattice_params, pack_batch
from .pressure import PressureProfile

__all__ = [
    "CLASS_NAMES",
    "DEFAULT_METHOD",
    "METHODS",
    "MethodInfo",
    "PressureProfile",
    "SimulationResult",
    "reset_times_batch",
    "simulate",
]

logger = logging.getLogger(__name__)

#: Unit class codes (``reset_times_batch()["unit_class"]``) and their names.
CLASS_NAMES: dict[int, str | None] = {
    CLASS_NEVER_INVERTED: None,
    CLASS_BISTABLE: "bistable",
    CLASS_METASTABLE: "metastable",
    CLASS_MONOSTABLE: "monostable",
}


@dataclass(frozen=True)
class MethodInfo:
    """One way of integrating the dynamics.

    Attributes
    ----------
    name : str
    model : str
        ``"full"`` (masses), ``"overdamped"`` (inertia dropped) or ``"release"`` (quasi-static
        loading, overdamped release).
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
    "radau": MethodInfo("radau", "full", -1, 1e-9, 0, math.inf),
}
DEFAULT_METHOD = "rodas4"


def _method(name: str) -> MethodInfo:
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"method = {name!r}: unknown; choose one of {sorted(METHODS)}") from None


@dataclass(frozen=True)
class SimulationResult:
    """One simulated scene.

    Attributes
    ----------
    design : Design
    profile : PressureProfile
    method : str
    status : Status
    t : ndarray of shape (m,), s
        Sample times (evenly spaced from 0 to ``t_end``).
    x : ndarray of shape (m, 4N - 2), mm
        Free coordinates at the samples (NaN past an early stop).
    tip : ndarray of shape (m, 2), mm
        Tip node ``L_N``.
    extensions : ndarray of shape (m, N)
        Dome extensions over their reach, ``u = x̄/d``.
    pressure : ndarray of shape (m,), MPa
    snap_through, snap_back : ndarray of shape (N,), s
        First upward and last downward threshold crossing (NaN if none).
    reset_time : ndarray of shape (N,), s
        After ``profile.t_release``; ``inf`` if still inverted at ``t_end``; NaN if never
        inverted.
    unit_class : tuple of (str or None)
        ``"bistable"``, ``"metastable"``, ``"monostable"`` or None (never inverted).
    final_state : str
        Inversion bits at the end, unit 1 first (e.g. ``"111100"``).
    events : ndarray of shape (n_events, 3)
        Every crossing: time (s), unit (1-based), direction (+1 snap-through, -1 snap-back).
    final_x, final_v : ndarray of shape (4N - 2,)
        State at the end of the run (mm, mm/s).
    t_end : float, s
        Requested end of the run; ``horizon = t_end - t_release``.
    stats : dict
        Steps, rejected steps, right-hand-side evaluations, factorisations, early stop.
    """

    design: Design
    profile: PressureProfile
    method: str
    status: st.Status
    t: NDArray[np.float64]
    x: NDArray[np.float64]
    tip: NDArray[np.float64]
    extensions: NDArray[np.float64]
    pressure: NDArray[np.float64]
    snap_through: NDArray[np.float64]
    snap_back: NDArray[np.float64]
    reset_time: NDArray[np.float64]
    unit_class: tuple[str | None, ...]
    final_state: str
    events: NDArray[np.float64]
    final_x: NDArray[np.float64]
    final_v: NDArray[np.float64]
    t_end: float
    stats: dict[str, int] = field(default_factory=dict)

    @property
    def horizon(self) -> float:
        """Time simulated after the end of the profile, s (the bound on an ``inf`` reset)."""
        return self.t_end - self.profile.t_release

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``null`` for never inverted, ``"inf"`` for never reset)."""

        def times(values, *, inf_text: bool) -> list:
            out = []
            for v in values:
                if math.isnan(v):
                    out.append(None)
                elif math.isinf(v):
                    out.append("inf" if inf_text else None)
                else:
                    out.append(round(float(v), 9))
            return out

        return {
            "final_state": self.final_state,
            "reset_times": times(self.reset_time, inf_text=True),
            "snap_through": times(self.snap_through, inf_text=False),
            "snap_back": times(self.snap_back, inf_text=False),
            "classes": list(self.unit_class),
            "status": self.status.label,
            "method": self.method,
            "horizon": self.horizon,
            "t_release": self.profile.t_release,
            "stats": dict(self.stats),
        }


def _controls(info: MethodInfo, *, t_release: float, atol, rtol, h_max, max_steps,
              stop_when_reset: bool) -> NDArray[np.float64]:  # fmt: skip
    ctrl = np.zeros(kev.N_CTRL)
    ctrl[kev.CTRL_RTOL] = 0.0 if rtol is None else _positive("rtol", rtol, allow_zero=True)
    ctrl[kev.CTRL_ATOL] = info.atol if atol is None else _positive("atol", atol)
    ctrl[kev.CTRL_H_MAX] = info.h_max if h_max is None else _positive("h_max", h_max)
    ctrl[kev.CTRL_MAX_STEPS] = info.max_steps if max_steps is None else _positive(
        "max_steps", max_steps
    )
    ctrl[kev.CTRL_TAU_END] = t_release
    ctrl[kev.CTRL_STOP_WHEN_RESET] = 1.0 if stop_when_reset else 0.0
    ctrl[kev.CTRL_H_MIN] = 1e-14
    if ctrl[kev.CTRL_ATOL] == 0.0 and ctrl[kev.CTRL_RTOL] == 0.0:
        raise ValueError("atol = 0 and rtol = 0: one tolerance must be positive")
    return ctrl


def _positive(name: str, value, *, allow_zero: bool = False) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0.0 or (value == 0.0 and not allow_zero):
        raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
    return value


def _check_horizon(t_end: float, profile: PressureProfile) -> float:
    t_end = float(t_end)
    if not math.isfinite(t_end) or t_end <= 0.0:
        raise ValueError(f"t_end = {t_end!r}: must be a finite time > 0 s")
    if t_end < profile.t_release:
        raise ValueError(
            f"t_end = {t_end} s: must not end before the pressure profile ({profile.t_release} s);"
            " reset times are measured from the end of the profile"
        )
    return t_end


def simulate(
    design: Design,
    profile: PressureProfile,
    *,
    t_end: float,
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
        Stop once past the profile with every inverted unit reset (the samples after that
        are NaN). Speeds up reset-time evaluation.
    event_capacity : int
        Crossings kept in ``events`` (all are counted).
    x0, v0 : ndarray of shape (4N - 2,), optional
        Initial free coordinates (mm) and velocities (mm/s) instead of the flat finger at
        rest (e.g. a stable state from :func:`dpfexplore.statics.find_state`). The overdamped
        models ignore ``v0``: their velocities follow from the positions.
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
    t_end = _check_horizon(t_end, profile)
    info = _method(method)
    if n_samples < 0:
        raise ValueError(f"n_samples = {n_samples!r}: must be >= 0")
    if info.name == "radau":
        from .dynamics_scipy import simulate_scipy

        custom = {"x0": x0 is not None, "v0": v0 is not None, "lattice": lattice is not None,
                  "eta": eta != kdyn.ETA_INTERNAL or eta_iso != kdyn.ETA_ISO}  # fmt: skip
        if any(custom.values()):
            raise ValueError(
                f"method = 'radau': the SciPy baseline runs the standard scene only; drop "
                f"{', '.join(k for k, v in custom.items() if v)}"
            )

        return simulate_scipy(design, profile, t_end=t_end, n_samples=n_samples,
                              atol=atol, rtol=rtol)  # fmt: skip
    if info.model == "release":
        raise ValueError(
            "method = 'release': the release model gives reset times only; use "
            "reset_times_batch(..., method='release') or dpfexplore.reduced.release_reset_times"
        )
    params = lattice_params(design) if lattice is None else lattice
    n_units = design.n_units
    if params.n_units != n_units:
        raise ValueError(f"lattice: has {params.n_units} units, the design {n_units}")
    n = 4 * n_units - 2
    knot_t, knot_p = profile.knots()
    ctrl = _controls(info, t_release=profile.t_release, atol=atol, rtol=rtol, h_max=h_max,
                     max_steps=max_steps, stop_when_reset=stop_when_reset)  # fmt: skip
    phys = np.array([
        _positive("eta", eta, allow_zero=True),
        _positive("eta_iso", eta_iso, allow_zero=True),
        kdyn.node_mass(n_units),
    ])
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
                raise ValueError(f"{name}: need {n} finite values (4N - 2), got shape "
                                 f"{value.shape}")  # fmt: skip
            y[part] = value
    t_out = np.linspace(0.0, t_end, n_samples) if n_samples else np.empty(0)
    x_out = np.full((n_samples, n), np.nan)
    rec = np.empty((n_units, kev.N_REC))
    log = np.zeros((event_capacity, 3))
    stats = np.zeros(kev.N_STATS, dtype=np.int64)
    code = integrate(info.integrator, y, 0.0, t_end, params.unit_params, params.h, knot_t,
                     knot_p, phys, ctrl, t_out, x_out, rec, log, stats)  # fmt: skip
    status = st.Status(code)
    if status != st.OK:
        logger.warning("simulate(%s, method=%s): %s", design.name or "design", method, status.label)
    return _result(design, profile, info.name, status, params, t_out, x_out, rec, log, stats,
                   y[:n].copy(), y[n:].copy(), t_end)  # fmt: skip


def _result(design, profile, method, status, params, t_out, x_out, rec, log, stats, final_x,
            final_v, t_end) -> SimulationResult:  # fmt: skip
    """Assemble a :class:`SimulationResult` from a run's arrays."""
    n_units = design.n_units
    reset = np.empty(n_units)
    snap_through = np.empty(n_units)
    snap_back = np.empty(n_units)
    classes = np.empty(n_units, dtype=np.int64)
    state = summarise_units(rec, profile.t_release, int(status), reset, snap_through, snap_back,
                            classes)  # fmt: skip
    tip, ext = _tip_and_extensions(params, x_out)
    n_events = int(min(stats[kev.STAT_EVENTS], log.shape[0]))
    events = log[:n_events].copy()
    events[:, 1] += 1.0
    return SimulationResult(
        design=design,
        profile=profile,
        method=method,
        status=status,
        t=t_out,
        x=x_out,
        tip=tip,
        extensions=ext,
        pressure=profile(t_out),
        snap_through=snap_through,
        snap_back=snap_back,
        reset_time=reset,
        unit_class=tuple(CLASS_NAMES[int(c)] for c in classes),
        final_state=format(state, f"0{n_units}b"),
        events=events,
        final_x=final_x,
        final_v=final_v,
        t_end=t_end,
        stats={
            "steps": int(stats[kev.STAT_STEPS]),
            "rejected": int(stats[kev.STAT_REJECTED]),
            "rhs_evaluations": int(stats[kev.STAT_RHS]),
            "factorisations": int(stats[kev.STAT_FACTOR]),
            "crossings": int(stats[kev.STAT_EVENTS]),
            "stopped_early": int(stats[kev.STAT_STOPPED_EARLY]),
        },
    )


def _tip_and_extensions(params, x_out: NDArray) -> tuple[NDArray, NDArray]:
    n_units = params.n_units
    m = x_out.shape[0]
    tip = np.full((m, 2), np.nan)
    ext = np.full((m, n_units), np.nan)
    pos = np.empty((2 * n_units + 2, 2))
    for j in range(m):
        if not np.isfinite(x_out[j, 0]):
            continue
        unpack_nodes(x_out[j], params.unit_params, params.h, pos)
        tip[j] = pos[2 * n_units + 1]
        dome_extensions(x_out[j], params.unit_params, params.h, pos, ext[j])
    return tip, ext


def empty_reset_columns(batch: DesignBatch) -> dict[str, NDArray]:
    """The arrays of the :func:`reset_times_batch` contract before any simulation.

    ``status`` is each design's input status; every output is NaN, -1 or "never inverted".
    """
    n = len(batch)
    return {
        "status": batch.status().astype(np.int8),
        "final_state": np.full(n, -1, dtype=np.int64),
        "reset_time": np.full((n, MAX_UNITS), np.nan),
        "snap_through": np.full((n, MAX_UNITS), np.nan),
        "snap_back": np.full((n, MAX_UNITS), np.nan),
        "unit_class": np.full((n, MAX_UNITS), CLASS_NEVER_INVERTED, dtype=np.int8),
    }


def reset_times_batch(
    batch: DesignBatch,
    profile: PressureProfile,
    *,
    t_end: float,
    method: str = DEFAULT_METHOD,
    atol: float | None = None,
    max_steps: int | None = None,
) -> dict[str, NDArray]:
    """Reset times of many designs under one profile, evaluated in parallel.

    Rows run in a Numba ``prange`` loop (:func:`dpfexplore._kernels.dynamics_batch.
    reset_times_kernel`): everything per row is compiled, ``nogil`` code, so there is nothing
    for Python threads to add, and the parallel region is one call with no per-row
    dispatch. Rows differ in cost by 10x or more (bistable designs run to the horizon,
    metastable ones stop when they reset), so the chunk size is set to 1 for the call: threads
    take rows as they free up instead of a fixed half each. Each run stops as soon as every
    inverted unit has reset after the profile ends.

    Parameters
    ----------
    batch : DesignBatch
    profile : PressureProfile
    t_end : float, s
        Horizon of every run.
    method : str
        Any Numba method of :data:`METHODS` (``"rodas4"`` by default) or ``"release"``.
    atol : float, optional, mm
    max_steps : int, optional

    Returns
    -------
    dict
        ``"status"`` (int8, (n,)), ``"final_state"`` (int64 (n,), unit 1 = most significant
        bit; -1 for invalid rows), ``"reset_time"``, ``"snap_through"``, ``"snap_back"``
        (float64 (n, 12), s; NaN for padding, invalid rows and units never inverted; reset
        ``inf`` if never reset within the horizon), ``"unit_class"`` (int8 (n, 12): 0
        bistable, 1 metastable, 2 monostable, -1 never inverted or padding). Invalid designs
        (``batch.status() != OK``) keep their status and NaN outputs.
    """
    if not isinstance(batch, DesignBatch):
        raise ValueError(f"batch = {batch!r}: must be a DesignBatch")
    t_end = _check_horizon(t_end, profile)
    info = _method(method)
    if info.model == "release":
        from .reduced import release_reset_times_batch

        return release_reset_times_batch(batch, profile, t_end=t_end, atol=atol)
    if info.integrator < 0:
        raise ValueError(f"method = {method!r}: not available for batches; use a Numba method")

    def launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out):
        reset_times_kernel(
            unit_params, h, n_units, valid, knot_t, knot_p, kdyn.ETA_INTERNAL, kdyn.ETA_ISO,
            info.model == "overdamped", info.integrator, ctrl, t_end, codes,
            out["final_state"], out["reset_time"], out["snap_through"], out["snap_back"],
            out["unit_class"],
        )  # fmt: skip

    return _run_reset_batch(batch, profile, info, atol, max_steps, launch)


def _run_reset_batch(batch, profile, info, atol, max_steps, launch) -> dict[str, NDArray]:
    """Pack ``batch``, run ``launch`` (a batch reset-time kernel) on it, return its columns.

    ``launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out)`` fills the
    columns of :func:`empty_reset_columns` in ``out`` and a status code per valid row in
    ``codes``; invalid designs keep their design status.
    """
    out = empty_reset_columns(batch)
    status = out["status"]
    n = len(batch)
    if n == 0:
        return out
    unit_params, h, n_units = pack_batch(batch)
    valid = status == st.OK
    knot_t, knot_p = profile.knots()
    ctrl = _controls(info, t_release=profile.t_release, atol=atol, rtol=None, h_max=None,
                     max_steps=max_steps, stop_when_reset=True)  # fmt: skip
    codes = np.zeros(n, dtype=np.int64)
    previous = numba.set_parallel_chunksize(1)
    try:
        launch(unit_params, h, n_units, valid, knot_t, knot_p, ctrl, codes, out)
    finally:
        numba.set_parallel_chunksize(previous)
    status[valid] = codes[valid].astype(np.int8)
    return out
