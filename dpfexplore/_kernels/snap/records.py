"""The snap walk's records: its output tables' layout, and the records its stages pass.

Layouts (column and counter indices) of what :func:`.snap.walk.follow` writes, read by the Python
side (:mod:`dpfexplore.solvers.snap`) through :mod:`.snap.walk`; and the named records
(module-level ``namedtuple`` classes, as :mod:`.records` explains) that :func:`.snap.walk.follow`
hands to its stages (:mod:`.snap.steps`).
"""

from __future__ import annotations

from collections import namedtuple

# ---- outputs -------------------------------------------------------------------------------

#: Columns of the event table.
EV_P = 0  # pressure, MPa
EV_KIND = 1  # KIND_SNAP or KIND_CROSSING
EV_BEFORE = 2  # state integer before (unit 1 = most significant bit)
EV_AFTER = 3  # state integer after
EV_CERT = 4  # landing's stability certificate (see certify_stable); inf for crossings
EV_SETTLE = 5  # s of motion simulated before the landing was accepted (0 for crossings)
EV_STEPS = 6  # Rodas4 steps of the landing
EV_DP = 7  # MPa past the fold at which the landing's motion settled (0 for crossings)
N_EV = 8

KIND_SNAP = 1
KIND_CROSSING = 2
#: A fold past which the motion did not settle on any equilibrium within the landing's time
#: budget (the walk stops there): the follower load is not conservative, and past some folds
#: of strongly curled fingers the motion is a slow relaxation oscillation instead.
KIND_UNSETTLED = 3

#: Columns of the path table (one row per accepted branch point, fold and landing).
PATH_P = 0  # MPa
PATH_SEGMENT = 1  # branch number: 0 from the start, +1 after each snap
PATH_STATE = 2  # state integer
PATH_TIP_X = 3  # mm
PATH_TIP_Y = 4  # mm
PATH_U = 5  # first of N columns: dome extension over reach, u = x̄/d
N_PATH_FIXED = 5

#: Counters.
CNT_EVENTS = 0  # events found (the table keeps at most its capacity)
CNT_PATH = 1  # path rows found
CNT_STEPS = 2  # accepted continuation steps
CNT_REJECTED = 3  # rejected continuation steps
CNT_LANDING_STEPS = 4  # Rodas4 steps of all landings
N_CNT = 5

# ---- records of one walk --------------------------------------------------------------
#
# :func:`.snap.walk.follow` is a loop over continuation steps; each stage of a step is a kernel of
# its own (:mod:`.snap.steps`) that reads and writes the walk's scratch (``FollowScratch``) and
# outputs (``WalkOutputs``) by name. Numba compiles the records as structs: no cost at run time.

#: What a walk writes: the event table ``ev`` (capacity, N_EV), the events' shapes ``ev_x``
#: (capacity or 0, 2, 4N - 2), the branch ``path`` (rows, N_PATH_FIXED + N), the ``counts``
#: (N_CNT,) and the last equilibrium ``x_final`` (4N - 2,).
WalkOutputs = namedtuple("WalkOutputs", ["ev", "ev_x", "path", "counts", "x_final"])
#: How a snap lands: the model ``phys`` and Rodas4 controls ``ctrl`` (:mod:`.dynamics.motion`,
#: :mod:`.dynamics.events`) and the kick (mm; ``<= 0``: :func:`default_kick`).
Landing = namedtuple("Landing", ["phys", "ctrl", "kick"])
#: Scratch of one walk. Points and tangents ``(x, p)`` of shape (4N - 1,): ``y0, t0`` the
#: current branch point, ``y1, t1`` the trial step, ``yb, tb`` where the step stops (fold or
#: end), ``yc, tc`` a located crossing; ``border`` the bordering row of the first correction;
#: unit margins ``g0, g1, gb`` at those points and ``gp`` for the path recorder; ``d_scale``
#: the per-unit step limits; the crossings of a step sorted by arclength (``cross_s``,
#: ``cross_k`` the unit, ``cross_x`` the point); the landing ``x_land`` and its ``info``
#: (``LAND_*``); ``ws`` the corrector's workspace (:func:`.snap.continuation.workspace`).
FollowScratch = namedtuple(
    "FollowScratch",
    [
        "y0",
        "t0",
        "y1",
        "t1",
        "yb",
        "tb",
        "yc",
        "tc",
        "border",
        "g0",
        "g1",
        "gb",
        "gp",
        "d_scale",
        "cross_s",
        "cross_k",
        "cross_x",
        "x_land",
        "info",
        "ws",
    ],
)

# ---- records of a batch of walks ------------------------------------------------------------

#: A rising walk, as its releases read it: its start ``x_start`` (4N - 2,), mm, at
#: ``p_start`` (MPa), its event table ``ev`` (capacity, N_EV), the events' shapes ``ev_x``
#: (capacity, 2, 4N - 2) and the number of its events ``n_events`` whose states to release.
RisingWalk = namedtuple("RisingWalk", ["x_start", "p_start", "ev", "ev_x", "n_events"])
#: What the releases of a rising walk write, one entry per visited state (0 = the start,
#: ``j`` = the state after event ``j - 1``): the release's ``status``, the ``state`` it ends in
#: and the pressure ``p`` of its first event (NaN: none).
Releases = namedtuple("Releases", ["status", "state", "p"])
#: The ramps of a batch: the rising walk ends at ``p_max``, every release at ``p_min`` (MPa);
#: ``release`` (bool) says whether to follow the releases at all.
Ramp = namedtuple("Ramp", ["p_max", "p_min", "release"])
#: How the landings of a batch are modelled: the :class:`~.records.Physics` ``physics``, the
#: Rodas4 controls ``ctrl`` and the ``kick`` (mm; ``<= 0``: :func:`.snap.landing.default_kick`).
BatchLanding = namedtuple("BatchLanding", ["physics", "ctrl", "kick"])
#: What :func:`.snap.walk.snap_batch` writes per design: the rising walk's ``status`` and number of
#: events ``n_events`` (n,), its ``events`` (n, capacity, N_EV), and per visited state
#: (n, capacity + 1) its release's ``release_status``, ``release_state`` and ``release_p``.
SnapRows = namedtuple(
    "SnapRows",
    ["status", "n_events", "events", "release_status", "release_state", "release_p"],
)
