"""Payload by pulling the disk out, and the sorting loop over many objects (``prange``).

Payload
    :func:`pull_out` gives the disk its degree of freedom along the gripper's axis by
    displacement control: the disk is moved away from the base in steps of ``pull_step`` and the
    fingers re-solved at each; the force along the axis that holds it there (the cage's normal
    forces plus, with friction sliding, ``μ`` times the normal forces' tangential share) is the
    weight that has an equilibrium at that position. The largest one on the path until the
    disk leaves the fingers (no contact) or the state is lost (a dome pushed back) is the payload;
    the peak is refined by the parabola through its step and the two beside it.
Sorting
    :func:`sort_batch` runs the classification loop for each object: close state by state until
    the sensor passes its threshold (the size class), then lift; if the payload of that state is
    below the object's weight, invert the tip unit (its held table) and lift again.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ...model import status as st
from .._jit import batch_kernel, kernel
from ..layout import n_free
from .equilibrium import grasp_solve, workspace
from .records import (
    G_CAGE,
    G_DOME1_FORCE,
    G_FRICTION,
    G_GRIP,
    G_HOLDS,
    G_STATUS,
    N_CONTACT_COLS,
    N_GRASP,
    N_SEG,
    Disk,
    GraspLattice,
)

#: Columns of :func:`sort_batch`'s output per object: the index of the deciding state (-1:
#: none), the sensor reading there (N), the weight class (``W_*``), the payloads (N) of that
#: state without and with the tip unit inverted, and the status of the last solve.
S_SIZE = 0
S_READING = 1
S_WEIGHT = 2
S_PAYLOAD = 3
S_PAYLOAD_TIP = 4
S_STATUS = 5
N_SORT = 6
W_LIGHT = 0
W_HEAVY = 1
W_NOT_HELD = 2

#: Columns of the pull-out result: payload force (N), where along the path it peaked (mm), the
#: steps taken, the status, and why the path ended (``END_*``).
P_FORCE = 0
P_AT = 1
P_STEPS = 2
P_STATUS = 3
P_END = 4
N_PULL = 5
END_RELEASED = 0  # no contact left: the disk is out
END_LOST = 1  # the state did not hold (a dome pushed back)
END_CAP = 2  # max_pull steps
END_FAILED = 3  # a solve failed


@kernel
def pull_out(x, lat, disk, contact, ctl, ws, seg, res):
    """Payload (N) of the grasp at ``x`` (an equilibrium with ``disk``): fills ``res`` (``P_*``).

    ``x`` and ``contact`` are the grasp's; both are changed along the path.
    """
    out = np.empty(N_GRASP)
    best = -math.inf
    best_at = 0.0
    prev = math.nan
    prev2 = math.nan
    end = END_CAP
    steps = 0
    status = st.OK
    # the grasp itself is step 0
    grasp_solve(x, lat, disk, contact, ctl, ws, seg, out)
    for i in range(ctl.max_pull + 1):
        if out[G_STATUS] != st.OK:
            end = END_FAILED
            status = int(out[G_STATUS])
            break
        if out[G_HOLDS] < 0.5:
            end = END_LOST
            break
        if i > 0 and out[G_GRIP] <= 0.0:
            end = END_RELEASED
            break
        held = out[G_CAGE] + disk.mu * out[G_FRICTION]
        if held > best:
            best = held
            best_at = i * ctl.pull_step
        elif i >= 2 and prev == best and math.isfinite(prev2):
            # parabola through the last three values: its vertex refines the peak
            denom = prev2 - 2.0 * prev + held
            if denom < 0.0:
                shift = 0.5 * (prev2 - held) / denom
                best = prev - 0.25 * (prev2 - held) * shift
                best_at = (i - 1 + shift) * ctl.pull_step
        prev2 = prev
        prev = held
        steps = i
        if i == ctl.max_pull:
            break
        moved = Disk(
            disk.cx + (i + 1) * ctl.pull_step * disk.ax,
            disk.cy + (i + 1) * ctl.pull_step * disk.ay,
            disk.radius,
            disk.offset,
            disk.ax,
            disk.ay,
            disk.mu,
        )
        grasp_solve(x, lat, moved, contact, ctl, ws, seg, out)
    res[P_FORCE] = max(best, 0.0)
    res[P_AT] = best_at
    res[P_STEPS] = steps
    res[P_STATUS] = status
    res[P_END] = end


@kernel
def _grasp_from_free(x0, lat, disk, ctl, ws, x, out):
    """Grasp from the free state ``x0`` with no shifts (into ``x``, ``out``); whether it solved.

    The same solve as the Python API's per-state grasp, so a batch row and a per-object call
    give the same numbers bit for bit.
    """
    n_units = lat.unit_params.shape[0]
    for i in range(x0.shape[0]):
        x[i] = x0[i]
    contact = np.zeros((n_units, N_CONTACT_COLS))
    grasp_solve(x, lat, disk, contact, ctl, ws, np.empty((n_units, N_SEG)), out)
    return out[G_STATUS] == st.OK


@kernel
def _pull_from_free(x0, lat, disk, ctl, ws, x, res):
    """Payload (``res``, ``P_*``) of the state at free shape ``x0``: its pull-out, no shifts.

    As the Python API's per-state payload (the pull-out grasps first, then pulls).
    """
    n_units = lat.unit_params.shape[0]
    for i in range(x0.shape[0]):
        x[i] = x0[i]
    pull_out(
        x, lat, disk, np.zeros((n_units, N_CONTACT_COLS)), ctl, ws, np.empty((n_units, N_SEG)), res
    )


@kernel
def decides(out, threshold):
    """Whether a grasp (``out``, ``G_*``) decides the size class at sensor ``threshold`` (N).

    The reading passes the threshold, or the object pushed a dome back (the state is lost: on
    its way over the barrier the dome's force passes its peak, far above any threshold).
    """
    return abs(out[G_DOME1_FORCE]) > threshold or out[G_HOLDS] < 0.5


@batch_kernel
def sort_batch(objects, setup, frame, ctl, result):
    """The sorting loop for each object (``prange``); fills ``result`` ``(n, N_SORT)``.

    Per object: close state by state (grasp from the state's free shape); the first state
    whose grasp :func:`decides` gives the size class; its payload (pull-out) against the
    object's weight gives ``W_LIGHT``; if it slips, the same state with the tip unit held
    inverted (its payload is computed only then: NaN otherwise), when the tip unit lasts the
    lift, ``W_HEAVY``; else ``W_NOT_HELD``. An infinite weight gives both payloads.

    Parameters
    ----------
    objects : ndarray of shape (n, 2)
        Diameter (mm) and weight (N) of each object.
    setup : SortSetup
        The finger's tables, the grasp states' free shapes and the sensor threshold.
    frame : ndarray of shape (6,)
        Disk centre ``cx``, ``cy`` (mm, model frame), axis ``ax``, ``ay``, surface offset (mm),
        friction coefficient ``μ``.
    ctl : GraspControls
    result : ndarray of shape (n, N_SORT)
    """
    n_obj = objects.shape[0]
    n_states = setup.x_free.shape[0]
    nf = n_free(setup.unit_params.shape[0])
    for o in prange(n_obj):
        ws = workspace()
        x = np.empty(nf)
        out = np.empty(N_GRASP)
        res = np.empty(N_PULL)
        disk = Disk(frame[0], frame[1], 0.5 * objects[o, 0], frame[4], frame[2], frame[3], frame[5])
        result[o, S_SIZE] = -1.0
        result[o, S_READING] = math.nan
        result[o, S_WEIGHT] = W_NOT_HELD
        result[o, S_PAYLOAD] = math.nan
        result[o, S_PAYLOAD_TIP] = math.nan
        result[o, S_STATUS] = st.OK
        for j in range(n_states):
            lat = GraspLattice(setup.unit_params, setup.h, setup.bits[j])
            if not _grasp_from_free(setup.x_free[j], lat, disk, ctl, ws, x, out):
                result[o, S_STATUS] = out[G_STATUS]
                break
            result[o, S_READING] = abs(out[G_DOME1_FORCE])
            if not decides(out, setup.threshold):
                continue
            result[o, S_SIZE] = j
            _pull_from_free(setup.x_free[j], lat, disk, ctl, ws, x, res)
            result[o, S_PAYLOAD] = res[P_FORCE]
            if res[P_FORCE] >= objects[o, 1]:
                result[o, S_WEIGHT] = W_LIGHT
                break
            # it slips: invert the tip unit and lift again
            held = GraspLattice(setup.held_params, setup.h, setup.held_bits[j])
            _pull_from_free(setup.x_held[j], held, disk, ctl, ws, x, res)
            result[o, S_PAYLOAD_TIP] = res[P_FORCE]
            if res[P_FORCE] >= objects[o, 1] and setup.tip_lasts:
                result[o, S_WEIGHT] = W_HEAVY
            break
