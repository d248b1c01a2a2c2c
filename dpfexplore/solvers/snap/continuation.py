"""Snap pressures: where a finger's units snap under a slow ramp of the chamber pressure.

>>> from dpfexplore import load_design
>>> from dpfexplore.solvers.snap.continuation import snap_pressures
>>> seq = snap_pressures(load_design("dpfexplore/examples/gripper.toml"), P_max=0.7)
>>> [(round(e.pressure, 4), e.before, e.after) for e in seq.events]  # doctest: +SKIP
[(0.0726, '00000', '00001'), (0.1131, '00001', '10001'), ...]

What "a slow ramp" means
    The quasi-static limit: the pressure rises so slowly that the finger is always at rest on an
    equilibrium branch ``R(x, P) = ∇E(x) - P f(x) = 0`` (MODEL.md §8 with the velocities zero),
    followed by pseudo-arclength continuation (:mod:`dpfexplore._kernels.snap.continuation`). Under
    a real ramp of rate ``r`` the finger lags: a smooth crossing by ``O(r)``, a snap by
    ``O(r^(2/3))`` (the slow passage through the saddle-node's ghost), so slow-ramp simulations
    converge to these pressures as the ramp slows (``tests/solvers/test_snap.py`` and ``dpfexplore
    bench snap`` measure it).
Events
    A *snap* happens where the branch folds (a real eigenvalue of the non-symmetric Jacobian
    ``K = H - P J_p`` crosses zero): the finger must leave the branch. A *crossing* is a unit's
    extension passing its inversion threshold smoothly along the branch (a dome with
    ``α >= 1/9`` has no barrier, and pressure can carry a dome over its isolated barrier without a
    jump); it changes the state's name, not the shape.
What decides what
    Inertia and damping do not enter the fold pressure (a property of the static branch); they
    decide where the finger lands after a snap, so the landing is simulated: the fold state is
    kicked by ``kick`` mm along the fold's null direction (toward the branch beyond the fold,
    the side the ramp pushes it; 0.1 mm, or less so that no dome moves by more than its reach)
    and the equations of motion run at the fold pressure (plus 1e-8 MPa) with Rodas4, full
    model by default or overdamped (``model=``), until Newton can polish the motion's end onto
    an equilibrium it certifies stable. The landing may differ from the state before in
    several units: a *cascade*, reported as one snap at one pressure with all those units
    (what a slow-ramp simulation shows as snap-through times a few ms apart). Past a very flat
    fold the motion may not settle within 400 s; it then runs 1e-5, then 1e-3 MPa past the fold
    (``SnapEvent.landing_offset``), as a slow ramp would carry it on. Past a few folds of
    strongly curled fingers it never settles (the follower load drives a slow relaxation
    oscillation): such an event is ``"unsettled"`` and ends the walk.
Tolerances
    Equilibria to 1e-9 N (largest residual force); a fold is located where the tangent's
    pressure component is below 1e-7 (the pressure error is quadratic in that: ~1e-13 MPa, far
    below the corrector's ~1e-10 MPa); crossings where ``|u - u_inv| < 1e-11``. Landings:
    Rodas4 at ``atol = 3e-3`` mm (only the basin matters: 1e-3 and 1e-2 mm landed where 1e-5
    and 1e-6 mm did on 168 snaps of random designs), accepted when Newton moves the motion's
    end by at most 0.2 mm onto an equilibrium certified stable.
Stability
    Every state reported is a stable equilibrium at its pressure. The load is not conservative,
    so "minimum" means linearly stable: the kernels certify it by a positive definite symmetric
    part of ``K`` (then every mode of the damped motion decays) or by the eigenvalues of
    ``C⁻¹K``; :func:`snap_pressures` re-checks every landing with the eigenvalues of the full
    linearised equations of motion (``SnapEvent.decay_rate``). The continuation detects folds,
    not Hopf bifurcations (a complex pair crossing, flutter, which the circulatory load could
    cause in principle); the tests check the eigenvalues along whole branches and found none.

Windows
    A state visited by a rising ramp holds on ``[P_enter, P_leave)``. Its *release* is where the
    finger ends if the pressure is then slowly let down to ``P_min`` from inside that window
    (the same for the whole window: it is one branch): that is what the gripper scene needs,
    whose grasp states (``10000``, ``11000``, ...) are the released states of the loaded ones
    (``10001``, ``11001``, ...: the metastable tip unit is inverted only under pressure).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..._kernels.dynamics import events as kevents
from ..._kernels.dynamics.batch import rest_state
from ..._kernels.dynamics.motion import ETA_INTERNAL, ETA_ISO, damping_matrix, node_mass
from ..._kernels.layout import n_free
from ..._kernels.records import Lattice
from ..._kernels.snap import continuation as kcont
from ..._kernels.snap import walk as ksnap
from ..._kernels.snap.records import Landing, WalkOutputs
from ...model import status as st
from ...model.design import Design
from ..compilation import announce
from ..lattice import LatticeParams, lattice_params, spring_constants
from ..statics import find_state, state_string
from .batch import inversion_pressures_batch, snap_pressures_batch
from .results import SnapEvent, SnapSequence, StateVisit
from .settings import DEFAULT_P_MAX, EVENT_CAPACITY, LANDING_MODELS, PATH_CAPACITY
from .settings import check_kick as _kick
from .settings import check_pressure as _pressure
from .settings import landing_model as _model

__all__ = [
    "DEFAULT_P_MAX",
    "LANDING_MODELS",
    "SnapEvent",
    "SnapSequence",
    "StateVisit",
    "decay_rate",
    "inversion_pressure",
    "inversion_pressures_batch",
    "snap_pressures",
    "snap_pressures_batch",
]

_KIND_NAMES = {
    ksnap.KIND_SNAP: "snap",
    ksnap.KIND_CROSSING: "crossing",
    ksnap.KIND_UNSETTLED: "unsettled",
}


class _Walk:
    """One kernel walk's raw outputs."""

    def __init__(
        self,
        params: LatticeParams,
        x0,
        p0,
        p_end,
        sign,
        phys,
        ctrl,
        kick,
        *,
        path_rows: int = PATH_CAPACITY,
    ):
        n = n_free(params.n_units)
        self.ev = np.empty((EVENT_CAPACITY, ksnap.N_EV))
        self.ev_x = np.empty((EVENT_CAPACITY, 2, n))
        self.path = np.empty((path_rows, ksnap.N_PATH_FIXED + params.n_units))
        self.counts = np.zeros(ksnap.N_CNT, dtype=np.int64)
        self.x_final = np.empty(n)
        self.x_start = np.array(x0, dtype=float)
        self.p_start = float(p0)
        self.sign = sign
        self.status = st.Status(
            int(
                ksnap.follow(
                    Lattice(params.unit_params, params.h),
                    self.x_start,
                    self.p_start,
                    float(p_end),
                    sign,
                    Landing(phys, ctrl, float(kick)),
                    WalkOutputs(self.ev, self.ev_x, self.path, self.counts, self.x_final),
                )
            )
        )
        self.n_events = int(min(self.counts[ksnap.CNT_EVENTS], EVENT_CAPACITY))
        self.n_path = int(min(self.counts[ksnap.CNT_PATH], path_rows))


def _state(params: LatticeParams, x: NDArray) -> str:
    """Inversion state of the shape ``x`` (unit 1 first)."""
    margins = np.empty(params.n_units)
    kevents.margins(x, params.unit_params, margins)
    return "".join("1" if g > 0.0 else "0" for g in margins)


def _flat(params: LatticeParams) -> NDArray:
    n = n_free(params.n_units)
    y = np.empty(2 * n)
    rest_state(params.unit_params, params.h, y)
    return y[:n].copy()


def decay_rate(params: LatticeParams, x: NDArray, pressure: float, model: str) -> float:
    """Slowest decay rate (1/s) of the motion linearised about the equilibrium ``x``.

    The eigenvalues of ``M v̈ + C v̇ + K v = 0`` (full model; ``C v̇ + K v = 0`` overdamped) with
    ``K = H - P J_p`` and the damping matrix ``C`` of MODEL.md §8 at ``x``; returns
    ``-max Re λ``: positive when every mode decays (a stable equilibrium). Dense LAPACK: for
    verification, not for the inner loops.
    """
    n_units = params.n_units
    n = n_free(n_units)
    ws = kcont.workspace(n_units)
    kcont.residual(
        np.asarray(x, dtype=float), float(pressure), params.unit_params, params.h, ws, True
    )
    k = ws[3].copy()
    c = np.empty((n, n))
    damping_matrix(ws[0], params.unit_params, params.h, ETA_INTERNAL, ETA_ISO, np.empty(n), c)
    if model == "rodas4-overdamped":
        lam = np.linalg.eigvals(-np.linalg.solve(c, k))
    else:
        m = node_mass(n_units)
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -k / m
        a[n:, n:] = -c / m
        lam = np.linalg.eigvals(a)
    return float(-np.max(lam.real))


def _after(row: NDArray, n_units: int) -> str:
    """State after an event ("" for an unsettled fold)."""
    after = int(row[ksnap.EV_AFTER])
    return state_string(after, n_units) if after >= 0 else ""


def _collect(
    walk: _Walk,
    n_units: int,
    direction: str,
    params,
    model,
    verify,
    events,
    visits,
    path_parts,
    segment_offset,
):
    """Append a walk's events, visits and path to the running lists; returns its segments."""
    state = _state(params, walk.x_start)
    entered = "turn" if visits else "start"  # a cycle's falling walk goes on from the top
    visits.append(StateVisit(state, direction, walk.p_start, math.nan, entered, None))
    for j in range(walk.n_events):
        row = walk.ev[j]
        kind = _KIND_NAMES[int(row[ksnap.EV_KIND])]
        rate = math.inf
        if kind == "snap" and verify:
            rate = decay_rate(params, walk.ev_x[j, 1], row[ksnap.EV_P], model)
        event = SnapEvent(
            pressure=float(row[ksnap.EV_P]),
            kind=kind,
            direction=direction,
            before=state_string(int(row[ksnap.EV_BEFORE]), n_units),
            after=_after(row, n_units),
            x_before=walk.ev_x[j, 0].copy(),
            x_after=walk.ev_x[j, 1].copy(),
            settle_time=float(row[ksnap.EV_SETTLE]),
            landing_steps=int(row[ksnap.EV_STEPS]),
            decay_rate=rate,
            landing_offset=float(row[ksnap.EV_DP]),
        )
        events.append(event)
        last = visits[-1]
        visits[-1] = StateVisit(
            last.state, last.direction, last.P_enter, event.pressure, last.entered_by, kind
        )
        if event.after:
            visits.append(StateVisit(event.after, direction, event.pressure, math.nan, kind, None))
    rows = walk.path[: walk.n_path]
    path_parts.append((rows, segment_offset))
    return int(rows[-1, ksnap.PATH_SEGMENT]) + 1 if len(rows) else 0


def _start(design, params, start_state, p_start, phys, ctrl, kick) -> tuple[NDArray, float]:
    """The stable equilibrium at ``p_start`` a walk starts from (see :func:`snap_pressures`)."""
    if start_state is None:
        x = _flat(params)
    else:
        found = find_state(design, start_state)
        if not found.stable:
            raise ValueError(
                f"start_state = {start_state!r}: not a stable state at P = 0"
                + (f" (it collapses to {found.found})" if found.found else "")
            )
        x = found.x
    if p_start == 0.0:
        return x, 0.0
    sign = 1 if p_start > 0.0 else -1
    approach = _Walk(params, x, 0.0, p_start, sign, phys, ctrl, kick, path_rows=0)
    if approach.status != st.OK:
        raise RuntimeError(
            f"P_start = {p_start}: the ramp from P = 0 to it failed ({approach.status.label})"
        )
    if start_state is not None and approach.n_events:
        first = approach.ev[0]
        raise ValueError(
            f"start_state = {start_state!r} does not last up to P_start = {p_start} MPa: it "
            f"changes at {first[ksnap.EV_P]:.6g} MPa"
        )
    return approach.x_final.copy(), p_start


def snap_pressures(
    design: Design,
    *,
    P_max: float = DEFAULT_P_MAX,
    P_min: float = 0.0,
    direction: Literal["up", "down", "cycle"] = "up",
    start_state: str | int | None = None,
    P_start: float | None = None,
    release: bool = True,
    model: str = "rodas4",
    kick: float | None = None,
    verify: bool = True,
) -> SnapSequence:
    """Follow a finger under a slow pressure ramp; every snap and crossing with its pressure.

    Parameters
    ----------
    design : Design
    P_max, P_min : float, MPa
        Top and bottom of the ramp (``P_min < P_max``).
    direction : {"up", "down", "cycle"}
        ``"up"``: from ``P_start`` to ``P_max``; ``"down"``: from ``P_start`` to ``P_min``
        (snap-back pressures); ``"cycle"``: up to ``P_max``, then down to ``P_min``.
    start_state : str or int, optional
        A state stable at ``P = 0`` to start from (default: the flat finger). It must last up to
        ``P_start``.
    P_start : float, MPa, optional
        Where the recorded walk starts: ``P_min`` for ``"up"`` and ``"cycle"``, ``P_max`` for
        ``"down"``. The finger gets there from ``P = 0`` by a slow ramp first (unrecorded).
    release : bool
        For rising walks, also let each visited state down to ``P_min``
        (:attr:`StateVisit.released`, :meth:`SnapSequence.release_windows`).
    model : {"rodas4", "rodas4-overdamped"}
        Equations of motion that decide each landing (with or without inertia).
    kick : float, mm, optional
        First displacement of a landing along the fold's null direction; by default 0.1 mm, or
        less if that would move a dome by more than its reach
        (:func:`dpfexplore._kernels.snap.landing.default_kick`).
    verify : bool
        Re-check every landing with the eigenvalues of the linearised motion (dense LAPACK,
        ~0.1-1 ms each); a landing that fails makes the status ``UNSTABLE``.

    Returns
    -------
    SnapSequence

    Raises
    ------
    ValueError
        Naming the argument: not a Design, bad pressures or direction, a start state that is
        not stable at ``P = 0`` or does not last to ``P_start``.
    RuntimeError
        The unrecorded ramp from ``P = 0`` to ``P_start`` failed (a failure of the recorded
        walk is reported in :attr:`SnapSequence.status` instead).
    """
    if not isinstance(design, Design):
        raise ValueError(f"design = {design!r}: must be a Design")
    P_max = _pressure("P_max", P_max)
    P_min = _pressure("P_min", P_min)
    if not P_min < P_max:
        raise ValueError(f"P_min = {P_min}, P_max = {P_max}: need P_min < P_max (MPa)")
    if direction not in ("up", "down", "cycle"):
        raise ValueError(f"direction = {direction!r}: choose 'up', 'down' or 'cycle'")
    if P_start is None:
        P_start = P_max if direction == "down" else P_min
    P_start = _pressure("P_start", P_start)
    if not P_min <= P_start <= P_max:
        raise ValueError(f"P_start = {P_start}: must lie in [P_min, P_max] = [{P_min}, {P_max}]")
    kick = _kick(kick)
    announce(["states", "snap"])  # the inputs are valid: say so before a first compilation
    n_units = design.n_units
    params = lattice_params(design)
    phys, ctrl = _model(model, n_units)
    x, p0 = _start(design, params, start_state, P_start, phys, ctrl, kick)

    events: list[SnapEvent] = []
    visits: list[StateVisit] = []
    path_parts: list[tuple[NDArray, int]] = []
    legs = {"up": [(P_max, 1)], "down": [(P_min, -1)], "cycle": [(P_max, 1), (P_min, -1)]}
    status = st.Status.OK
    segment = 0
    stats = {"steps": 0, "rejected": 0, "landing_steps": 0, "walks": 0}
    for p_end, sign in legs[direction]:
        walk = _Walk(params, x, p0, p_end, sign, phys, ctrl, kick)
        stats["walks"] += 1
        for key, col in (
            ("steps", ksnap.CNT_STEPS),
            ("rejected", ksnap.CNT_REJECTED),
            ("landing_steps", ksnap.CNT_LANDING_STEPS),
        ):
            stats[key] += int(walk.counts[col])
        first_visit = len(visits)
        segment += _collect(
            walk,
            n_units,
            "up" if sign > 0 else "down",
            params,
            model,
            verify,
            events,
            visits,
            path_parts,
            segment,
        )
        if sign > 0 and release:
            _release(params, walk, visits, first_visit, P_min, phys, ctrl, kick, stats)
        if walk.status != st.OK:
            status = walk.status
            break
        x, p0 = walk.x_final.copy(), p_end
    if status == st.OK and verify and any(not e.decay_rate > 0.0 for e in events):
        status = st.Status.UNSTABLE
    path = _path_columns(path_parts, n_units)
    stats["events"] = len(events)
    return SnapSequence(
        design=design,
        direction=direction,
        P_start=P_start,
        P_max=P_max,
        P_min=P_min,
        status=status,
        events=tuple(events),
        visits=tuple(visits),
        path=path,
        final_x=x,
        model=model,
        fitted_range=design.in_fitted_range,
        no_contact=tuple(bool(v) for v in spring_constants(design).no_contact),
        stats=stats,
    )


def _release(
    params, walk: _Walk, visits: list[StateVisit], first: int, p_min: float, phys, ctrl, kick, stats
) -> None:
    """Fill ``released`` and ``P_release_leave`` of the visits of a rising walk."""
    m = len(visits) - first  # the visits: one per event but an unsettled last one, and the start
    rel_status = np.zeros(m, dtype=np.int64)
    rel_state = np.full(m, -1, dtype=np.int64)
    rel_p = np.full(m, np.nan)
    landing = Landing(phys, ctrl, float(kick))
    _release_walks(params, walk, m, float(p_min), landing, rel_status, rel_state, rel_p)
    for j in range(m):
        v = visits[first + j]
        released = state_string(int(rel_state[j]), params.n_units) if rel_state[j] >= 0 else None
        visits[first + j] = StateVisit(
            v.state,
            v.direction,
            v.P_enter,
            v.P_leave,
            v.entered_by,
            v.left_by,
            released,
            float(rel_p[j]),
        )
    stats["release_walks"] = stats.get("release_walks", 0) + m


def _release_walks(params, walk: _Walk, m: int, p_min: float, landing, status, state, p) -> None:
    """:func:`dpfexplore._kernels.snap.walk.release_walks` of the first ``m`` states of ``walk``.

    The same walks, each a call of the compiled :func:`~dpfexplore._kernels.snap.walk.follow`
    from here: one design's few releases gain nothing from a compiled loop around them, and
    ``follow`` is the kernel this module compiles anyway (the batch compiles the loop inline).
    Fills ``status``, ``state`` (-1: the walk failed) and ``p`` (the first event's pressure on
    the way down, MPa; NaN: none) of state ``j`` (0 = the start, ``j`` = after event ``j - 1``).
    """
    n_units = params.n_units
    nf = n_free(n_units)
    lattice = Lattice(params.unit_params, params.h)
    ev = np.empty((walk.ev.shape[0], ksnap.N_EV))
    counts = np.zeros(ksnap.N_CNT, dtype=np.int64)
    x_final = np.empty(nf)
    outputs = WalkOutputs(
        ev, np.empty((0, 2, nf)), np.empty((0, ksnap.N_PATH_FIXED + n_units)), counts, x_final
    )
    g = np.empty(n_units)
    for j in range(m):
        if j > 0 and walk.ev[j - 1, ksnap.EV_KIND] == ksnap.KIND_CROSSING:
            status[j] = status[j - 1]
            state[j] = state[j - 1]
            p[j] = walk.ev[j - 1, ksnap.EV_P]
            continue
        if j == 0:
            p_entry = walk.p_start
            x_entry = walk.x_start.copy()
        else:
            p_entry = float(walk.ev[j - 1, ksnap.EV_P])
            x_entry = walk.ev_x[j - 1, 1].copy()
        code = ksnap.follow(lattice, x_entry, p_entry, p_min, ksnap.FALLING, landing, outputs)
        status[j] = code
        kevents.margins(x_final, params.unit_params, g)
        label = 0
        for k in range(n_units):
            label = 2 * label + (1 if g[k] > 0.0 else 0)
        state[j] = label if code == st.OK else -1
        p[j] = ev[0, ksnap.EV_P] if counts[ksnap.CNT_EVENTS] > 0 else np.nan


def _path_columns(parts, n_units: int) -> dict[str, NDArray]:
    rows = [r for r, _ in parts]
    table = np.concatenate(rows) if rows else np.zeros((0, ksnap.N_PATH_FIXED + n_units))
    segment = (
        np.concatenate([r[:, ksnap.PATH_SEGMENT] + off for r, off in parts])
        if rows
        else np.zeros(0)
    )
    return {
        "P": table[:, ksnap.PATH_P].copy(),
        "segment": segment.astype(np.int64),
        "state": table[:, ksnap.PATH_STATE].astype(np.int64),
        "tip": table[:, ksnap.PATH_TIP_X : ksnap.PATH_TIP_Y + 1].copy(),
        "u": table[:, ksnap.PATH_U : ksnap.PATH_U + n_units].copy(),
    }


def inversion_pressure(
    design: Design, unit: int, *, P_max: float = DEFAULT_P_MAX, model: str = "rodas4"
) -> float:
    """Pressure (MPa) at which ``unit`` (1-based) first inverts under a slow ramp from flat.

    ``inf`` if it does not invert by ``P_max``. Raises ``ValueError`` for a bad unit, and
    ``RuntimeError`` if the walk fails before the unit inverts.
    """
    if (
        isinstance(unit, bool)
        or not isinstance(unit, (int, np.integer))
        or not 1 <= unit <= design.n_units
    ):
        raise ValueError(f"unit = {unit!r}: must be an integer in 1..{design.n_units}")
    seq = snap_pressures(design, P_max=P_max, release=False, model=model)
    value = float(seq.inversion_pressures()[unit - 1])
    if math.isnan(value):
        raise RuntimeError(f"the slow ramp failed ({seq.status.label}) before unit {unit} inverted")
    return value
