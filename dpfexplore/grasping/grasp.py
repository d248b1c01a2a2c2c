"""One object in every grasp state: contact, grip force, sensor, payload, whether it holds.

For each grasp state the finger is solved against the disk (fixed on the axis), starting from
the free state and growing the disk into place (:mod:`dpfexplore._kernels.grasp`); the other
finger is its mirror image. The payload is the largest weight the state holds with the disk free
to move along the axis (gripper pointing down), found by pulling the disk out in steps; with
``mu = 0`` it is the cage alone. The same is done with the tip unit inverted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model.design import Design
from ..model.gripper import gripper_frame
from .setup import GRAVITY, GraspOptions, Gripper, gripper_of, state_bits

__all__ = ["GraspReport", "StateGrasp", "check_object", "deciding_state", "grasp", "tip_reset_time"]


@dataclass(frozen=True)
class StateGrasp:
    """The grasp of the disk in one state (units in the names; frames: gripper's, MODEL.md §7).

    Attributes
    ----------
    state : str
        Inversion vector, unit 1 first.
    status : str
        ``ok`` or the solver's failure.
    contact : bool
        Whether the disk touches the finger (a positive normal force).
    grip_force_N : float
        Sum of one finger's normal forces on the disk.
    sensor_N, sensor_change_N : float
        The sensor's reading (magnitude of unit 1's dome force) and its change from the free
        state.
    detects : bool
        Whether this state decides the size class: ``sensor_N > threshold``, or the object
        pushed a dome back (the state is lost; on its way over the barrier the dome's force
        passes its peak, far above any threshold).
    payload_kg, payload_N : float
        Largest weight held (disk free along the axis, gripper pointing down).
    holds : bool
        The state's inversion vector survives the grasp (False: a dome was pushed back).
    cage_N, friction_N : float
        At the grasp position, both fingers' normal forces along the axis toward the base, and
        both fingers' ``Σ f |t·a|`` (times ``μ``: friction's share of the holding force).
    penetration_mm : float
        Largest penetration left (at most the tolerance).
    deviation_mm : float
        Largest node displacement from the free state.
    forces_N : ndarray of shape (N,)
        Normal force of each limiting-layer segment (unit k's) on the disk.
    points_mm : ndarray of shape (N, 2)
        Contact point of each segment (closest point of the inner surface; gripper frame).
    normals : ndarray of shape (N, 2)
        Unit normal from each point toward the disk's centre (gripper frame).
    nodes_mm : ndarray of shape (2N + 2, 2)
        The finger's nodes at equilibrium (gripper frame).
    """

    state: str
    status: str
    contact: bool
    grip_force_N: float
    sensor_N: float
    sensor_change_N: float
    detects: bool
    payload_kg: float
    payload_N: float
    holds: bool
    cage_N: float
    friction_N: float
    penetration_mm: float
    deviation_mm: float
    forces_N: NDArray = field(repr=False)
    points_mm: NDArray = field(repr=False)
    normals: NDArray = field(repr=False)
    nodes_mm: NDArray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record."""
        return {
            "state": self.state,
            "status": self.status,
            "contact": self.contact,
            "grip_force_N": self.grip_force_N,
            "sensor": self.sensor_N,
            "sensor_change": self.sensor_change_N,
            "payload_kg": self.payload_kg,
            "holds": self.holds,
            "penetration_mm": self.penetration_mm,
            "deviation_mm": self.deviation_mm,
            "forces_N": [float(f) for f in self.forces_N],
        }


@dataclass(frozen=True)
class GraspReport:
    """:func:`grasp`'s result: per grasp state, and per state with the tip unit inverted.

    Attributes
    ----------
    diameter_mm, mass_kg, mu, depth_mm, threshold_N : float
    states, tip_states : tuple of StateGrasp
    apertures_mm : ndarray of shape (n_states,)
    size_state : str or None
        The first grasp state whose reading passes the threshold.
    tip_reset_s : float or None
        Reset time of the tip unit after its pulse (s); None when not computed.
    lift_s : float or None
        The lift's duration (s), as given.
    gripper : Gripper
    """

    diameter_mm: float
    mass_kg: float
    mu: float
    depth_mm: float
    threshold_N: float
    states: tuple[StateGrasp, ...]
    tip_states: tuple[StateGrasp, ...]
    apertures_mm: NDArray
    size_state: str | None
    tip_reset_s: float | None
    lift_s: float | None
    gripper: Gripper = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready document (keys carry their units)."""
        rows = []
        for s, tip, ap in zip(self.states, self.tip_states, self.apertures_mm, strict=True):
            row = s.to_dict()
            row["aperture_mm"] = float(ap)
            row["threshold"] = self.threshold_N
            row["tip_inverted"] = {
                "state": tip.state,
                "payload_kg": tip.payload_kg,
                "grip_force_N": tip.grip_force_N,
                "holds": tip.holds,
                "status": tip.status,
            }
            rows.append(row)
        return {
            "object": {"diameter_mm": self.diameter_mm, "mass_kg": self.mass_kg},
            "mu": self.mu,
            "depth_mm": self.depth_mm,
            "threshold_N": self.threshold_N,
            "size_state": self.size_state,
            "tip_reset_s": self.tip_reset_s,
            "lift_s": self.lift_s,
            "states": rows,
        }


def check_object(diameter: float, mass: float, mu: float, open_aperture: float | None) -> None:
    """Refuse a diameter <= 0 or wider than the open gripper, a negative mass or ``mu``."""
    for name, value in (("diameter", diameter), ("mass", mass), ("mu", mu)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ValueError(f"{name} = {value!r}: must be a finite number")
    if diameter <= 0:
        raise ValueError(f"diameter = {diameter:g} mm: must be > 0")
    if open_aperture is not None and diameter > open_aperture:
        raise ValueError(
            f"diameter = {diameter:g} mm: larger than the open gripper ({open_aperture:.2f} mm)"
        )
    if mass < 0:
        raise ValueError(f"mass = {mass:g} kg: must be >= 0")
    if mu < 0:
        raise ValueError(f"mu = {mu:g}: must be >= 0")


def _disk(gripper: Gripper, diameter: float, depth: float, mu: float):
    from .._kernels.grasp.records import Disk

    c = gripper.to_model([depth, gripper.base_L])
    a = gripper.axis_model()
    offset = 0.5 * gripper.design.t_lim
    return Disk(float(c[0]), float(c[1]), 0.5 * diameter, offset, float(a[0]), float(a[1]), mu)


def solve_state(gripper: Gripper, j: int, disk, ctl, *, held: bool = False, payload: bool = True):
    """Grasp and payload of state ``j`` (tip inverted with ``held``); returns kernel arrays."""
    from .._kernels.grasp.batch import N_PULL, P_FORCE, pull_out
    from .._kernels.grasp.equilibrium import grasp_solve, workspace
    from .._kernels.grasp.records import N_CONTACT_COLS, N_GRASP, N_SEG, GraspLattice

    n = gripper.design.n_units
    table = gripper.held_params if held else gripper.unit_params
    state = gripper.held_states[j] if held else gripper.states[j]
    x0 = gripper.x_held[j] if held else gripper.x_free[j]
    lat = GraspLattice(table, gripper.h, state_bits(state))
    ws = workspace()
    x = x0.copy()
    contact = np.zeros((n, N_CONTACT_COLS))
    seg = np.empty((n, N_SEG))
    out = np.empty(N_GRASP)
    grasp_solve(x, lat, disk, contact, ctl, ws, seg, out)
    force = math.nan
    if payload:
        res = np.empty(N_PULL)
        pull_out(x0.copy(), lat, disk, np.zeros((n, N_CONTACT_COLS)), ctl, ws, seg.copy(), res)
        force = float(res[P_FORCE])
    return x, seg, out, force


def _record(gripper, j, x, seg, out, payload_n, threshold, held) -> StateGrasp:
    from .._kernels.grasp import records as r
    from .._kernels.lattice import unpack_nodes
    from ..model.status import Status

    n = gripper.design.n_units
    state = gripper.held_states[j] if held else gripper.states[j]
    status = Status(int(out[r.G_STATUS])).label
    pos = np.empty((2 * n + 2, 2))
    free = np.empty((2 * n + 2, 2))
    unpack_nodes(x, gripper.unit_params, gripper.h, pos)
    x0 = gripper.x_held[j] if held else gripper.x_free[j]
    unpack_nodes(x0, gripper.unit_params, gripper.h, free)
    theta = gripper.theta_B_deg
    c, s = math.cos(math.radians(theta)), math.sin(math.radians(theta))
    rot = np.array([[c, -s], [s, c]])
    ok = status == "ok"
    forces = seg[:, r.SEG_FORCE].copy() if ok else np.full(n, math.nan)
    points = gripper_frame(seg[:, [r.SEG_PX, r.SEG_PY]], gripper.h, theta)
    normals = seg[:, [r.SEG_NX, r.SEG_NY]] @ rot.T
    reading = abs(float(out[r.G_DOME1_FORCE]))
    free_reading = gripper.free_readings[j + 1]
    return StateGrasp(
        state=state,
        status=status,
        contact=bool(ok and out[r.G_GRIP] > 0.0),
        grip_force_N=float(out[r.G_GRIP]),
        sensor_N=reading,
        sensor_change_N=reading - float(free_reading),
        detects=bool(ok and (reading > threshold or out[r.G_HOLDS] < 0.5)),
        payload_kg=payload_n / GRAVITY,
        payload_N=payload_n,
        holds=bool(ok and out[r.G_HOLDS] > 0.5),
        cage_N=float(out[r.G_CAGE]),
        friction_N=float(out[r.G_FRICTION]),
        penetration_mm=float(out[r.G_PENETRATION]),
        deviation_mm=float(np.max(np.hypot(*(pos - free).T))),
        forces_N=forces,
        points_mm=points,
        normals=normals,
        nodes_mm=gripper_frame(pos, gripper.h, theta),
    )


def deciding_state(states) -> str | None:
    """The size class of the loop: the first state that decides, None if none does.

    The loop stops at a state whose solve failed (no class), as the sorting kernel does.
    """
    for s in states:
        if s.status != "ok":
            return None
        if s.detects:
            return s.state
    return None


def tip_reset_time(design: Design, profile=None, t_end: float = 2.0) -> float:
    """Reset time (s) of the tip unit after a pulse that inverts it (the gripper scene's pulse).

    ``profile`` defaults to the gripper scene's: ``P0 = 0.7`` MPa, ``τ = (0, 0.5, 1.0, 1.1)`` s,
    over ``t_end`` s. ``inf`` when it does not reset within the horizon, NaN when never inverted.
    """
    from ..model.design import DesignBatch
    from ..model.pressure import PressureProfile
    from ..solvers.dynamics.simulate import reset_times_batch

    if profile is None:
        profile = PressureProfile.pulse(0.7, (0.0, 0.5, 1.0, 1.1))
    out = reset_times_batch(DesignBatch.from_designs([design]), profile, t_end=t_end)
    return float(out["reset_time"][0, design.n_units - 1])


def grasp(
    design: Design | Gripper,
    diameter: float,
    mass: float = 0.0,
    *,
    mu: float = 0.0,
    depth: float | None = None,
    threshold: float | None = None,
    margin: float = 0.1,
    lift_s: float | None = None,
    reset: bool = False,
    options: GraspOptions | None = None,
) -> GraspReport:
    """Close the gripper on a disk in every grasp state; contact, sensor, payload, holding.

    Parameters
    ----------
    design : Design or Gripper
        The finger (on the paper's base) or a gripper from :func:`gripper_of`.
    diameter : float, mm
    mass : float, kg
    mu : float
        Coulomb friction coefficient at the contacts.
    depth : float, optional, mm
        Disk centre's depth along the axis (default: :meth:`Gripper.default_depth`).
    threshold : float, optional, N
        Sensor threshold; default the largest free-state reading times ``1 + margin``.
    lift_s : float, optional, s
        The lift's duration, reported beside the tip unit's reset time.
    reset : bool
        Compute the tip unit's reset time (runs the dynamics).
    options : GraspOptions, optional
    """
    gripper = design if isinstance(design, Gripper) else gripper_of(design)
    check_object(diameter, mass, mu, gripper.open_aperture)
    if not (0.0 <= margin and math.isfinite(margin)):
        raise ValueError(f"margin = {margin!r}: must be a finite number >= 0")
    if threshold is not None and not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold = {threshold!r} N: must be a finite number > 0")
    options = options or GraspOptions()
    ctl = options.controls(gripper.unit_params)
    depth = gripper.default_depth() if depth is None else float(depth)
    if not math.isfinite(depth):
        raise ValueError(f"depth = {depth!r} mm: must be a finite number")
    thr = gripper.threshold(margin) if threshold is None else float(threshold)
    disk = _disk(gripper, float(diameter), depth, float(mu))
    states, tips = [], []
    for j in range(len(gripper.states)):
        x, seg, out, pay = solve_state(gripper, j, disk, ctl)
        states.append(_record(gripper, j, x, seg, out, pay, thr, False))
        x, seg, out, pay = solve_state(gripper, j, disk, ctl, held=True)
        tips.append(_record(gripper, j, x, seg, out, pay, thr, True))
    size = deciding_state(states)
    return GraspReport(
        diameter_mm=float(diameter),
        mass_kg=float(mass),
        mu=float(mu),
        depth_mm=depth,
        threshold_N=thr,
        states=tuple(states),
        tip_states=tuple(tips),
        apertures_mm=gripper.apertures,
        size_state=size,
        tip_reset_s=tip_reset_time(gripper.design) if reset else None,
        lift_s=lift_s,
        gripper=gripper,
    )
