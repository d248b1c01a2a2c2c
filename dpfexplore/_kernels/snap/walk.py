"""Snap pressures: follow a finger's equilibrium under a slow pressure ramp, snap at each fold.

:func:`follow` continues the equilibrium branch from a stable state (:mod:`.snap.continuation`) as
the pressure rises (``sign = +1``) or falls (``-1``), and records two kinds of event:

* a *crossing*: a unit's extension passes its inversion threshold ``u_inv`` smoothly along the
  branch (the state label changes, nothing jumps; e.g. a dome with ``α >= 1/9`` has no barrier
  and its extension just grows through ``u = 3/4``);
* a *snap*: the branch folds (a real eigenvalue of ``K`` crosses zero and the branch turns back
  in pressure). The fold is located to the corrector's tolerance, and the finger's landing is
  decided by the dynamics (:mod:`.snap.landing`): the fold state is kicked along the branch's
  direction of travel and the equations of motion (MODEL.md §8, Rodas4, full or overdamped) run
  at the fold pressure plus a small offset until the motion has settled onto an equilibrium
  that Newton polishes at the fold pressure and certifies stable. The
  continuation resumes from there. A cascade (several units going at once) is one snap whose
  landing differs from the state before it in several units.

Why the fold pressure needs no dynamics but the landing does: in the limit of a slow ramp the
finger follows its stable branch quasi-statically, and inertia and damping only act once that
branch ends; so the pressure of the snap is the fold's (a slow ramp overshoots it by a delay
that vanishes as ``rate^(2/3)``, the passage through a saddle-node), while where the finger comes
to rest depends on how its motion carries it (which units a cascade takes along).

:func:`snap_batch` runs the rising ramp from the flat finger for many designs in parallel and,
for every state visited, the release from where it was entered down to ``P_min``.

Each continuation step of :func:`follow` is a sequence of stages, kernels of their own in
:mod:`.snap.steps`; the output tables' layout (``EV_*``, ``PATH_*``, ``CNT_*``) and the records
the stages pass are in :mod:`.snap.records`, and are named here too.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ...model import status as st
from .._jit import batch_kernel, kernel
from ..dynamics.batch import rest_state
from ..dynamics.events import margins
from ..layout import n_free
from ..records import Lattice
from .continuation import PRESSURE_SCALE
from .landing import LAND_CERT, LAND_OFFSET, LAND_SECONDS, LAND_STEPS
from .records import (
    CNT_EVENTS,
    CNT_LANDING_STEPS,
    CNT_PATH,
    CNT_REJECTED,
    CNT_STEPS,
    EV_AFTER,
    EV_BEFORE,
    EV_CERT,
    EV_DP,
    EV_KIND,
    EV_P,
    EV_SETTLE,
    EV_STEPS,
    KIND_CROSSING,
    KIND_SNAP,
    KIND_UNSETTLED,
    N_CNT,
    N_EV,
    N_PATH_FIXED,
    PATH_P,
    PATH_SEGMENT,
    PATH_STATE,
    PATH_TIP_X,
    PATH_TIP_Y,
    PATH_U,
    Landing,
    Releases,
    RisingWalk,
    WalkOutputs,
)
from .steps import (
    DS_GROW,
    DS_INIT,
    DS_MAX,
    DS_MIN,
    EASY_ITER,
    MAX_STEPS,
    MAX_TURN,
    STOP_END,
    STOP_FOLD,
    STOP_NONE,
    crossings,
    record_crossings,
    record_path,
    scratch,
    snap,
    start,
    state_of,
    step_stop,
    trial_step,
)

#: The ``sign`` of :func:`follow`: pressure rising or falling along the path (int64, not
#: literals: see the package docstring).
RISING = np.int64(1)
FALLING = np.int64(-1)

__all__ = [
    "CNT_EVENTS",
    "CNT_LANDING_STEPS",
    "CNT_PATH",
    "CNT_REJECTED",
    "CNT_STEPS",
    "EV_AFTER",
    "EV_BEFORE",
    "EV_CERT",
    "EV_DP",
    "EV_KIND",
    "EV_P",
    "EV_SETTLE",
    "EV_STEPS",
    "KIND_CROSSING",
    "KIND_SNAP",
    "KIND_UNSETTLED",
    "N_CNT",
    "N_EV",
    "N_PATH_FIXED",
    "PATH_P",
    "PATH_SEGMENT",
    "PATH_STATE",
    "PATH_TIP_X",
    "PATH_TIP_Y",
    "PATH_U",
    "follow",
    "release_walks",
    "snap_batch",
    "state_of",
]


@kernel
def follow(lattice, x_start, p_start, p_end, sign, landing, out):
    """Follow the equilibrium from ``(x_start, p_start)`` to ``p_end``, snapping at folds.

    Parameters
    ----------
    lattice : Lattice
        Lattice parameters ``unit_params``, ``h`` (:mod:`.records`, :mod:`.layout`).
    x_start : ndarray of shape (4N - 2,), mm
        A stable equilibrium at ``p_start`` (polished here).
    p_start, p_end : float, MPa
    sign : int
        +1: rising pressure (``p_end > p_start``), -1: falling.
    landing : Landing
        Model ``phys`` and Rodas4 controls ``ctrl`` of the landings (:mod:`.dynamics.motion`,
        :mod:`.dynamics.events`), and the ``kick`` (mm): first displacement of each landing along
        the fold's null direction (:func:`land`); ``<= 0``: :func:`default_kick`.
    out : WalkOutputs
        Receives the events in order ``ev`` (capacity, N_EV; ``EV_*`` columns), each event's
        shape before and after ``ev_x`` (capacity or 0, 2, 4N - 2; skipped if empty), the
        branch points ``path`` (rows, N_PATH_FIXED + N; ``PATH_*`` columns, as many as fit),
        the ``CNT_*`` ``counts`` (int64, (N_CNT,)) and ``x_final`` (4N - 2,), the equilibrium
        at ``p_end`` (or where the walk stopped).

    Returns
    -------
    int
        ``OK``; ``NOT_CONVERGED`` (a step or a landing failed), ``STEP_LIMIT`` (step cap or
        event table full), ``UNSTABLE`` (the start is not a stable equilibrium),
        ``DEGENERATE_GEOMETRY`` or ``NONFINITE``.

    Notes
    -----
    Each step, by the stages of :mod:`.snap.steps`: a trial step (``trial_step``, halved until
    accepted), where it stops (``step_stop``), the crossings before that (``crossings``; a stop
    or crossing that cannot be located rejects the step), then the crossings' events
    (``record_crossings``) and, at a fold, the landing (``snap``).
    """
    unit_params, h = lattice
    path = out.path
    counts = out.counts
    x_final = out.x_final
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    for i in range(N_CNT):
        counts[i] = 0
    s = scratch(unit_params, sign)
    p_end_s = p_end * PRESSURE_SCALE

    for i in range(n):
        x_final[i] = x_start[i]
    code = start(x_start, p_start, unit_params, h, landing.phys, s)
    if code != st.OK:
        if code == st.UNSTABLE:
            for i in range(n):
                x_final[i] = s.y0[i]
        return code
    margins(s.y0[:n], unit_params, s.g0)
    label = state_of(s.g0, n_units)
    segment = np.int64(0)  # int64, not a literal: see the package docstring
    record_path(s.y0, segment, label, unit_params, h, s.gp, path, counts)
    if sign * (s.y0[n] - p_end_s) >= 0.0:
        for i in range(n):
            x_final[i] = s.y0[i]
        return st.OK
    ds = DS_INIT
    cos_turn = math.cos(MAX_TURN)
    while True:
        for i in range(n):
            x_final[i] = s.y0[i]
        if counts[CNT_STEPS] + counts[CNT_REJECTED] >= MAX_STEPS:
            return st.STEP_LIMIT
        accept, iters = trial_step(ds, cos_turn, unit_params, h, s)
        if not accept:
            counts[CNT_REJECTED] += 1
            ds *= 0.5
            if ds < DS_MIN:
                return st.NOT_CONVERGED
            continue
        # An event that cannot be located (a corrector inside the step that does not converge,
        # on a sharply curved branch) rejects the step: a shorter one brackets it closer.
        failed, stop, s_stop = step_stop(ds, sign, p_end_s, unit_params, h, s)
        n_cross = 0
        if not failed:
            failed, n_cross = crossings(s_stop, p_end_s, unit_params, h, s)
        if failed:
            counts[CNT_REJECTED] += 1
            ds *= 0.5
            if ds < DS_MIN:
                return st.NOT_CONVERGED
            continue
        counts[CNT_STEPS] += 1
        if stop != STOP_NONE:
            for i in range(n + 1):
                s.y1[i] = s.yb[i]
                s.t1[i] = s.tb[i]
        s.info[LAND_CERT] = np.inf
        s.info[LAND_SECONDS] = 0.0
        s.info[LAND_STEPS] = 0.0
        s.info[LAND_OFFSET] = 0.0
        room, label = record_crossings(n_cross, label, segment, unit_params, h, out, s)
        if not room:
            return st.STEP_LIMIT

        if stop == STOP_END:
            record_path(s.y1, segment, label, unit_params, h, s.gp, path, counts)
            for i in range(n):
                x_final[i] = s.y1[i]
            return st.OK
        if stop == STOP_FOLD:
            code, label, segment = snap(label, segment, sign, unit_params, h, landing, out, s)
            if code != st.OK:
                return code
            ds = DS_INIT
            continue
        for i in range(n + 1):
            s.y0[i] = s.y1[i]
            s.t0[i] = s.t1[i]
        for k in range(n_units):
            s.g0[k] = s.g1[k]
        record_path(s.y0, segment, label, unit_params, h, s.gp, path, counts)
        if iters <= EASY_ITER:
            ds = min(ds * DS_GROW, DS_MAX)


@batch_kernel
def snap_batch(lattice, valid, ramp, landing, out):
    """The rising ramp from the flat finger, and each visited state's release, for many designs.

    Parameters
    ----------
    lattice : LatticeBatch
        Padded batch tables (:func:`dpfexplore.solvers.lattice.pack_batch`, :mod:`.records`).
    valid : ndarray of bool, shape (n,)
        Which rows to run.
    ramp : Ramp
        End of the rising ramp ``p_max`` and of every release ``p_min`` (MPa); ``release``:
        also follow each visited state down to ``p_min``.
    landing : BatchLanding
        Model of the landings (damping, N·s/mm; node masses of ``mass_per_unit · N / (2N + 2)``
        tonne, 0: inertia dropped), their Rodas4 controls and the kick (mm; see :func:`follow`).
    out : SnapRows
        Status of the rising walk and its number of events (int64), its events, and for
        visited state ``j`` (0 = the flat start, ``j`` = after event ``j - 1``) the status of
        its release, the state it ends in at ``p_min`` and the pressure of the first event on
        the way down (NaN: none, the state lasts down to ``p_min``).

    Notes
    -----
    A state entered by a smooth crossing lies on the same branch as the state before it, so its
    release retraces the crossing (its first event on the way down) and then that state's
    release: only the start and each landing need a walk of their own.
    """
    unit_params, h, n_units = lattice
    p_max, p_min, release = ramp
    # a record handed into the prange body must be an argument (Numba's parfor lowering rebuilds
    # only those), so the landing's physics is read into scalars here
    eta = landing.physics.eta
    eta_iso = landing.physics.eta_iso
    mass_per_unit = landing.physics.mass_per_unit
    ctrl = landing.ctrl
    kick = landing.kick
    status, n_events, events, release_status, release_state, release_p = out
    n = unit_params.shape[0]
    capacity = events.shape[1]
    for i in prange(n):
        if not valid[i]:
            continue
        nu = n_units[i]
        params = unit_params[i, :nu]
        nf = n_free(nu)
        phys = np.empty(3)
        phys[0] = eta
        phys[1] = eta_iso
        phys[2] = mass_per_unit * nu / (2.0 * nu + 2.0)
        y = np.empty(2 * nf)
        rest_state(params, h[i], y)
        ev_x = np.empty((capacity, 2, nf))
        path = np.empty((0, N_PATH_FIXED + nu))
        counts = np.zeros(N_CNT, dtype=np.int64)
        x_final = np.empty(nf)
        one = Lattice(params, h[i])
        walk_landing = Landing(phys, ctrl, kick)
        code = follow(
            one,
            y[:nf],
            0.0,
            p_max,
            RISING,
            walk_landing,
            WalkOutputs(events[i], ev_x, path, counts, x_final),
        )
        status[i] = code
        ne = min(counts[CNT_EVENTS], capacity)
        n_events[i] = ne
        if ne > 0 and events[i, ne - 1, EV_KIND] == KIND_UNSETTLED:
            ne -= 1  # no state after it to release
        if release:
            release_walks(
                one,
                RisingWalk(y[:nf], 0.0, events[i], ev_x, ne),
                p_min,
                walk_landing,
                Releases(release_status[i], release_state[i], release_p[i]),
            )


@kernel(inline="always")
def release_walks(lattice, rising, p_min, landing, out):
    """Release each state of a rising walk (start, then its events) down to ``p_min``.

    ``rising`` is the walk (:class:`~.snap.records.RisingWalk`), started at ``(x_start,
    p_start)``; fills entry ``j`` (0 = the start, ``j`` = the state after event ``j - 1``) of
    ``out`` (:class:`~.snap.records.Releases`; see :func:`snap_batch`). Compiled inline into
    :func:`snap_batch` (its only caller in the kernels: no machine code of its own).
    """
    # attribute reads, not unpacking: compiled inline into the batch's prange body, unpacking a
    # record built there trips Numba's array analysis (docs/decisions.md, "Less to compile")
    unit_params = lattice.unit_params
    x_start = rising.x_start
    p_start = rising.p_start
    ev = rising.ev
    ev_x = rising.ev_x
    n_events = rising.n_events
    release_status = out.status
    release_state = out.state
    release_p = out.p
    n_units = unit_params.shape[0]
    nf = n_free(n_units)
    capacity = ev.shape[0]
    ev2 = np.empty((capacity, N_EV))
    ev2_x = np.empty((0, 2, nf))
    path = np.empty((0, N_PATH_FIXED + n_units))
    counts = np.zeros(N_CNT, dtype=np.int64)
    x_final = np.empty(nf)
    walk = WalkOutputs(ev2, ev2_x, path, counts, x_final)
    g = np.empty(n_units)
    x_entry = np.empty(nf)
    for j in range(n_events + 1):
        if j > 0 and ev[j - 1, EV_KIND] == KIND_CROSSING:
            release_status[j] = release_status[j - 1]
            release_state[j] = release_state[j - 1]
            release_p[j] = ev[j - 1, EV_P]
            continue
        if j == 0:
            p_entry = p_start
            for i in range(nf):
                x_entry[i] = x_start[i]
        else:
            p_entry = ev[j - 1, EV_P]
            for i in range(nf):
                x_entry[i] = ev_x[j - 1, 1, i]
        code = follow(lattice, x_entry, p_entry, p_min, FALLING, landing, walk)
        release_status[j] = code
        margins(x_final, unit_params, g)
        release_state[j] = state_of(g, n_units) if code == st.OK else -1
        release_p[j] = ev2[0, EV_P] if counts[CNT_EVENTS] > 0 else np.nan
