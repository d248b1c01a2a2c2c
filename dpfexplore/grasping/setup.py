"""The gripper a grasp runs on: finger tables, grasp states, the disk's frame, the controls.

Decisions (docs/decisions.md, "Grasp and sorting"):

* The grasp states are the pressure sequence's states with units ``1..k`` inverted,
  ``k = 1 .. N - 1`` (the paper's ``10000 … 11110``); the last unit is the tip unit, inverted
  only for the stiffer grasp.
* The tip unit inverted: when the state with it inverted is stable, that state; otherwise (the
  paper's metastable tip) its dome held at the isolated dome's inverted rest (its reach ``d``
  without one), the point the state search holds an inverted dome at: the shape right after its
  pulse, which lasts until the unit resets (its reset time is reported beside the lift).
* The disk's centre sits on the axis at ``depth`` along it (mm, gripper frame); by default the
  mean depth of the grasp states' fingertips, where each state's aperture is measured.
* The inner surface is the limiting layer's mid-line moved by ``t_lim / 2`` toward the disk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model.design import Design
from ..model.gripper import PAPER_GRIPPER_BASE, gripper_aperture
from ..solvers.lattice import lattice_params
from ..solvers.statics import find_state, state_string

__all__ = ["GraspOptions", "Gripper", "gripper_of"]

#: Standard gravity (m/s²): weights of masses in kg are ``m g`` newtons.
GRAVITY = 9.80665


@dataclass(frozen=True)
class GraspOptions:
    """Controls of the contact solve.

    Attributes
    ----------
    tol : float, mm
        Largest penetration of the disk into a finger at a solution.
    kappa : float or None, N/mm
        Penalty stiffness; None: half the base unit's limiting-layer stiffness ``k_lim``.
    eps : float, mm
        Width over which the penalty's curvature rises from 0 to ``kappa`` (C² smoothing).
    pull_step : float, mm
        Step of the disk along the axis when its payload is found.
    grow : float, mm
        Largest radius increment while an overlapping disk is grown into place.
    max_outer : int
        Augmented-Lagrangian updates before a solve gives up.
    """

    tol: float = 1e-4
    kappa: float | None = None
    eps: float = 0.01
    pull_step: float = 0.5
    grow: float = 1.0
    max_outer: int = 200

    def __post_init__(self) -> None:
        for name in ("tol", "eps", "pull_step", "grow"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {value!r}: must be a finite number > 0")
        if self.kappa is not None and not (math.isfinite(self.kappa) and self.kappa > 0):
            raise ValueError(f"kappa = {self.kappa!r}: must be a finite number > 0 (N/mm)")
        if isinstance(self.max_outer, bool) or not (
            isinstance(self.max_outer, int) and self.max_outer >= 1
        ):
            raise ValueError(f"max_outer = {self.max_outer!r}: must be an integer >= 1")

    def controls(self, unit_params: NDArray):
        """The kernels' :class:`~dpfexplore._kernels.grasp.records.GraspControls`."""
        from .._kernels.grasp.records import GraspControls
        from .._kernels.layout import COL_KLIM

        kappa = self.kappa if self.kappa is not None else 0.5 * float(unit_params[0, COL_KLIM])
        max_pull = 400
        return GraspControls(
            1e-9,
            1e-8,
            200,
            1.0,
            float(kappa),
            float(self.eps),
            float(self.tol),
            int(self.max_outer),
            float(self.grow),
            float(self.pull_step),
            max_pull,
        )


@dataclass(frozen=True)
class Gripper:
    """A finger on the gripper's base, solved in its grasp states.

    Attributes
    ----------
    design : Design
    base_L : float, mm
    theta_B_deg : float, degrees
    h : float, mm
        Segment height.
    unit_params, held_params : ndarray of shape (N, N_COLS)
        The finger's kernel table, and that table with the tip unit held inverted.
    states, held_states : tuple of str
        Grasp states (inversion vectors, unit 1 first) and each with the tip unit inverted.
    x_free, x_held : ndarray of shape (n_states, 4N - 2), mm
        Free shapes of each grasp state, without and with the tip unit inverted.
    stable : ndarray of bool, shape (n_states,)
        Whether each grasp state exists (stable) in this model.
    apertures : ndarray of shape (n_states,), mm
        The free gripper's aperture in each state.
    tip_depths : ndarray of shape (n_states,), mm
        Depth of the fingertip along the axis (gripper frame) in each state.
    open_aperture : float, mm
        Aperture of the open gripper (no unit inverted).
    free_readings : ndarray of shape (n_states + 1,), N
        The sensor's reading in the open state and each free grasp state.
    """

    design: Design
    base_L: float
    theta_B_deg: float
    h: float
    unit_params: NDArray
    held_params: NDArray
    states: tuple[str, ...]
    held_states: tuple[str, ...]
    x_free: NDArray
    x_held: NDArray
    stable: NDArray
    apertures: NDArray
    tip_depths: NDArray
    open_aperture: float
    free_readings: NDArray

    def to_model(self, points) -> NDArray:
        """Points of the gripper frame (mm) in the finger's model frame."""
        theta = math.radians(self.theta_B_deg)
        c, s = math.cos(theta), math.sin(theta)
        p = np.asarray(points, dtype=float)
        return np.stack(
            [c * p[..., 0] + s * p[..., 1], -s * p[..., 0] + c * p[..., 1] + self.h], -1
        )

    def axis_model(self) -> NDArray:
        """Unit vector of the axis, away from the base, in the model frame."""
        theta = math.radians(self.theta_B_deg)
        return np.array([math.cos(theta), -math.sin(theta)])

    def default_depth(self) -> float:
        """Mean fingertip depth of the stable grasp states (mm): where apertures are measured."""
        depths = self.tip_depths[self.stable]
        return float(np.mean(depths)) if depths.size else float(np.mean(self.tip_depths))

    def threshold(self, margin: float) -> float:
        """Sensor threshold (N): the largest free-state reading times ``1 + margin``."""
        return float(np.max(self.free_readings)) * (1.0 + margin)


def _held_table(unit_params: NDArray) -> NDArray:
    from .._kernels.layout import COL_KB, COL_PEN, COL_U_HELD, COL_U_HI, COL_U_LO

    table = unit_params.copy()
    tip = table[-1]
    tip[COL_U_LO] = tip[COL_U_HELD]
    tip[COL_U_HI] = tip[COL_U_HELD]
    tip[COL_PEN] = 1e3 * tip[COL_KB]
    return np.ascontiguousarray(table)


def _free_reading(unit_params: NDArray, h: float, x: NDArray) -> float:
    from .._kernels.lattice import dome_law, unpack_nodes
    from .._kernels.layout import COL_P

    pos = np.empty((2 * unit_params.shape[0] + 2, 2))
    unpack_nodes(x, unit_params, h, pos)
    ext = float(np.hypot(*(pos[2] - pos[0]))) - unit_params[0, COL_P]
    return abs(float(dome_law(ext, unit_params[0])[1]))


def gripper_of(
    design: Design,
    *,
    base_L: float = PAPER_GRIPPER_BASE[0],
    theta_B_deg: float = PAPER_GRIPPER_BASE[1],
) -> Gripper:
    """Solve ``design``'s grasp states on the base (``base_L`` mm, ``theta_B_deg`` degrees)."""
    from ..solvers.compilation import announce

    announce(["states", "grasp"])
    from .._kernels.grasp.equilibrium import grasp_solve, workspace
    from .._kernels.grasp.records import N_CONTACT_COLS, N_GRASP, N_SEG, Disk, GraspLattice

    for name, value in (("base_L", base_L), ("theta_B_deg", theta_B_deg)):
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ValueError(f"{name} = {value!r}: must be a finite number")
    n = design.n_units
    if n < 2:
        raise ValueError(f"n_units = {n}: a gripper finger needs at least 2 units")
    lp = lattice_params(design)
    table = np.ascontiguousarray(lp.unit_params)
    held = _held_table(table)
    states = tuple("1" * k + "0" * (n - k) for k in range(1, n))
    held_states = tuple(s[:-1] + "1" for s in states)
    open_state = find_state(design, "0" * n)
    free = [find_state(design, s) for s in states]
    x_free = np.ascontiguousarray(np.array([r.x for r in free]))
    stable = np.array([r.stable for r in free])
    tips = np.array([r.tip for r in free])
    apertures = np.asarray(gripper_aperture(tips, lp.h, base_L, theta_B_deg), dtype=float)
    theta = math.radians(theta_B_deg)
    tip_depths = (tips[:, 0]) * math.cos(theta) - (tips[:, 1] - lp.h) * math.sin(theta)
    # the tip held inverted: from the free state, relaxed with the hold on and no disk
    ws = workspace()
    ctl = GraspOptions().controls(table)
    x_held = x_free.copy()
    far = Disk(0.0, 1e6, 0.0, 0.0, 1.0, 0.0, 0.0)
    out = np.empty(N_GRASP)
    for j, s in enumerate(held_states):
        lat = GraspLattice(held, lp.h, np.array([int(b) for b in s], dtype=np.int64))
        contact = np.zeros((n, N_CONTACT_COLS))
        grasp_solve(x_held[j], lat, far, contact, ctl, ws, np.empty((n, N_SEG)), out)
    readings = [_free_reading(table, lp.h, open_state.x)]
    readings += [_free_reading(table, lp.h, r.x) for r in free]
    return Gripper(
        design=design,
        base_L=float(base_L),
        theta_B_deg=float(theta_B_deg),
        h=float(lp.h),
        unit_params=table,
        held_params=held,
        states=states,
        held_states=held_states,
        x_free=x_free,
        x_held=np.ascontiguousarray(x_held),
        stable=stable,
        apertures=apertures,
        tip_depths=np.asarray(tip_depths, dtype=float),
        open_aperture=float(gripper_aperture(open_state.tip, lp.h, base_L, theta_B_deg)),
        free_readings=np.array(readings),
    )


def state_bits(state: str) -> NDArray:
    """Inversion vector of a state string as int64 bits, unit 1 first."""
    return np.array([int(b) for b in state], dtype=np.int64)


__all__ += ["GRAVITY", "state_bits", "state_string"]
