"""One dome unit under apex displacement control: the shell model's curve.

:func:`unit_cell_curve` traces the equilibrium path of a pinned spherical cap whose apex is
pushed toward inversion, through every fold, with the geometrically exact, shear-rigid
axisymmetric shell of :mod:`dpfexplore._kernels.shell.energy` (the formulation, its checks and what
it neglects: ``docs/guide/unitcell.md``). :class:`UnitCellRun` holds the path;
:meth:`UnitCellRun.to_frame` is the table ``dpfexplore identify fit`` reads.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .._kernels.shell import path as shell_path
from .._kernels.shell.energy import assemble, nodes
from .._kernels.shell.records import PathControls
from ..solvers.compilation import announce
from .geometry import Plate, check_inputs, check_path_size, reference_unknowns, shell
from .path import (
    GhostState,
    PathSamples,
    ZeroForceState,
    branch_ids,
    find_ghost,
    find_stepped_over_rests,
    find_zero_force_states,
    work_along_path,
)

__all__ = [
    "DEFAULT_ELEMENTS",
    "UnitCellRun",
    "apex_stiffness",
    "unit_cell_curve",
]

#: Elements along the meridian by default: doubling them changes the energy curve by less than
#: 0.1 % over the paper's box (docs/guide/unitcell.md, tests/unitcell/test_convergence.py).
DEFAULT_ELEMENTS = 128
#: Default travel, in dome heights: past the inverted zero-force state (about 2 H).
DEFAULT_TRAVEL = 2.2
#: Default travel of a dome in its unit cell's plate, in dome heights: the plate's rest lies
#: further (2.1-2.3 H over the paper's box).
PLATE_TRAVEL = 2.5
#: Largest continuation step, as a fraction of the travel (weighted arclength,
#: :mod:`dpfexplore._kernels.shell.path`): a simple dome takes 150-250 steps.
DEFAULT_STEP = 1.0 / 60.0

_STATUS = {
    shell_path.REACHED: "reached",
    shell_path.MAX_STEPS: "max_steps",
    shell_path.BACKWARD: "backward",
    shell_path.STEP_TOO_SMALL: "step_too_small",
}
_MESSAGES = {
    "reached": "the path reached the requested travel",
    "max_steps": "stopped after max_steps steps before the requested travel",
    "backward": "the path returned to negative apex travel",
    "step_too_small": "the continuation step fell below its floor (corrector failing)",
    "no_path": (
        "the corrector failed at the undeformed dome: no point of the path (a geometry the "
        "discretised shell does not resolve)"
    ),
}
#: Why a path stopped short, in the message of a ``partial`` run.
_STOPPED = {
    "max_steps": "max_steps steps taken",
    "backward": "it returned to negative apex travel",
    "step_too_small": "corrector failing",
}


def _partial_message(stopped: str) -> str:
    return (
        f"the path stopped before the requested travel ({_STOPPED[stopped]}); the inverted "
        "branch was traced from the dome's mirror image and appended as its own branches"
    )


_ANNOUNCED: list[bool] = []


def _announce() -> None:
    """Once per process: say that the shell kernels compile (first run only), then load them.

    A tiny trace compiles (or loads from Numba's cache) every kernel a run calls, so that
    :attr:`UnitCellRun.elapsed` is run time only.
    """
    if _ANNOUNCED:
        return
    _ANNOUNCED.append(True)
    announce(["unit-cell shell"])
    geom = shell(1.0, 0.1, 2.0, 1.0, 0.3, 4)
    y = reference_unknowns(geom)
    _trace(geom, 0.2, 0.1, 3, 1e-9, 1e-12, y, 1.0, False)
    shell_path.equilibrate_free(y.copy(), geom, 1e-9, 1e-12)
    shell_path.relax(y.copy(), geom, True, 1e-9, 2)
    r, z = np.empty(5), np.empty(5)
    nodes(y, geom, r, z)
    assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)


@dataclass(frozen=True, eq=False)
class UnitCellRun:
    """The equilibrium path of one dome unit under apex displacement control.

    Every array has one entry per point of the path, in path (arclength) order from the
    undeformed dome.

    Attributes
    ----------
    H, t, r_b : float, mm
        Dome height, thickness and base radius (mid-surface).
    E : float, MPa
    nu : float
    n_elements : int
        Segments along the meridian.
    displacement : ndarray (n_steps,), mm
        Apex travel toward inversion, starting at 0.
    force : ndarray (n_steps,), N
        Apex reaction ``dΠ/dδ`` (positive: the dome pushes back).
    energy, membrane_energy, bending_energy : ndarray (n_steps,), N·mm
        Total strain energy and its two parts.
    stable : ndarray of bool (n_steps,)
        Stable under displacement control (free Hessian at fixed travel positive definite).
    instability_index : ndarray of int (n_steps,)
        Negative eigenvalues of that Hessian (-1: singular to working precision).
    branch : ndarray of int (n_steps,)
        Branch id: 0 from the start, +1 at every fold (limit point in the travel).
    shapes : ndarray (n_steps, n_elements + 1, 2), mm
        Deformed meridian ``(r, z)``, apex first.
    arclength : ndarray (n_steps,)
        Weighted arclength of the continuation (mm), for plotting against a monotone abscissa.
    work : ndarray (n_steps,), N·mm
        ``∫ F dδ`` from the start (Hermite quadrature per step): equals ``energy`` on a sound path.
    initial_stiffness : float, N/mm
        ``dF/dδ`` at the undeformed dome.
    zero_force_states : tuple of ZeroForceState
        Equilibria at zero apex force found on the path (the undeformed dome excluded).
    tip_dis : float or None, mm
        The inverted apex travel the lattice's reach is built from (MODEL.md §3): the travel of
        the stable zero-force inverted state (apex free, resting with no load and no contact:
        the dome's own inverted rest; of the lowest energy if several; next to the bistable edge
        possibly one the path stepped over, then not among ``zero_force_states``), else that of
        the ghost (``ghost``), else None. ``tip_kind`` says which. Why not contact with a rigid
        wall: ``docs/guide/unitcell.md``, "The inverted apex travel".
    tip_kind : str or None
        ``"rest"``, ``"ghost"`` or None (neither: a dome whose force only rises past ``H``).
    status : str
        ``reached``; ``partial`` when the path stopped early and the inverted branch, traced
        separately from the mirror image, follows it (its points after a gap, its work restarted
        at its own energy); else ``max_steps``, ``backward`` or ``step_too_small``.
        ``message`` says it in words.
    elapsed : float, s
        Wall time of the trace (compilation excluded).
    gap : int or None
        With status ``partial``: the index of the last point of the traced path, after which
        the separately traced inverted branch follows (not connected to it); None otherwise.
    ghost : GhostState or None
        Without an inverted rest: the least force past ``H`` (``dF/dδ = 0``, ``F > 0``), the
        remnant of the lost rest (:mod:`.path`); None when the dome rests inverted or its force
        has no minimum there.
    plate : Plate or None
        The unit cell's plate around the cap (:class:`~.geometry.Plate`; ``shapes`` then hold
        its nodes after the cap's), or None: the cap pinned at ``r_b``.
    """

    H: float
    t: float
    r_b: float
    E: float
    nu: float
    n_elements: int
    displacement: NDArray
    force: NDArray
    energy: NDArray
    membrane_energy: NDArray
    bending_energy: NDArray
    stable: NDArray
    instability_index: NDArray
    branch: NDArray
    shapes: NDArray
    arclength: NDArray
    work: NDArray
    initial_stiffness: float
    zero_force_states: tuple[ZeroForceState, ...]
    tip_dis: float | None
    tip_kind: str | None
    status: str
    message: str
    elapsed: float
    tangents: NDArray = field(repr=False)
    gap: int | None = None
    ghost: GhostState | None = None
    plate: Plate | None = None

    @property
    def success(self) -> bool:
        """True when the path reached the requested travel."""
        return self.status == "reached"

    @property
    def n_steps(self) -> int:
        """Points on the path (the undeformed dome included)."""
        return int(self.displacement.size)

    @property
    def R(self) -> float:
        """Dome radius of curvature, mm (MODEL.md §2)."""
        return (self.r_b**2 + self.H**2) / (2.0 * self.H)

    @property
    def folds(self) -> NDArray:
        """Apex travel (mm) at the last point of every branch before a fold (limit point)."""
        ends = np.flatnonzero(np.diff(self.branch) > 0)
        return self.displacement[ends[ends != self.gap]]

    @property
    def bistable(self) -> bool:
        """A stable zero-force inverted state exists on the path."""
        return self.tip_kind == "rest"

    def energy_envelope(self, displacement: NDArray) -> NDArray:
        """Lowest energy (N·mm) any branch reaches at each ``displacement`` (mm); inf outside all.

        The curve a slow displacement-controlled test follows when it jumps at the folds, and
        the curve ``identify`` fits. Within a branch (monotone in the travel) the energy is
        interpolated by cubic Hermite polynomials with the force as its slope (fourth order, so
        the envelope's error is the model's, not the interpolation's).
        """
        from scipy.interpolate import CubicHermiteSpline

        grid = np.asarray(displacement, dtype=float)
        envelope = np.full(grid.shape, np.inf)
        for key in np.unique(self.branch):
            on = self.branch == key
            x, first = np.unique(self.displacement[on], return_index=True)
            if x.size < 2:
                continue
            e, f = self.energy[on][first], self.force[on][first]
            inside = (grid >= x[0]) & (grid <= x[-1])
            values = CubicHermiteSpline(x, e, f)(grid[inside])
            envelope[inside] = np.minimum(envelope[inside], values)
        return envelope

    def to_frame(self, curve: str | int | None = None) -> pd.DataFrame:
        """The path as the table ``dpfexplore identify fit`` reads (``identification.curves``).

        Columns ``curve, H, t, r_b, E, nu, displacement, energy, force, branch`` and, when the
        run has one (an inverted rest or a ghost), ``tip_dis`` (left out otherwise: ``identify``
        refuses missing values).
        """
        if curve is None:
            curve = f"H{self.H:g}_t{self.t:g}_rb{self.r_b:g}_E{self.E:g}_nu{self.nu:g}"
        n = self.n_steps
        columns = {
            "curve": [curve] * n,
            "H": np.full(n, self.H),
            "t": np.full(n, self.t),
            "r_b": np.full(n, self.r_b),
            "E": np.full(n, self.E),
            "nu": np.full(n, self.nu),
            # round-off can put the first point a hair below 0; identify refuses x < 0
            "displacement": np.maximum(self.displacement, 0.0),
            "energy": self.energy,
            "force": self.force,
            "branch": self.branch,
        }
        if self.tip_dis is not None:
            columns["tip_dis"] = np.full(n, self.tip_dis)
        return pd.DataFrame(columns)


def _tolerances(H: float, t: float, E: float) -> tuple[float, float]:
    # Forces scale like E t² (Reissner's stiffness times a travel of order t); positions like H.
    return 1e-10 * E * t * t, 1e-10 * max(H, t)


def _elements(n_elements) -> int:
    if n_elements is None:
        return DEFAULT_ELEMENTS
    if isinstance(n_elements, bool) or not isinstance(n_elements, int | np.integer):
        raise ValueError(f"n_elements={n_elements!r}: must be an integer")
    if not 4 <= n_elements <= 5000:
        raise ValueError(f"n_elements={n_elements!r}: must be between 4 and 5000")
    return int(n_elements)


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
        raise ValueError(f"{name}={value!r}: must be a number (mm)")
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name}={value!r}: must be finite and > 0 (mm)")
    return float(value)


def _grading(grading) -> float:
    if not isinstance(grading, int | float) or not 0.0 <= grading <= 0.9:
        raise ValueError(f"grading={grading!r}: must be a number in [0, 0.9]")
    return float(grading)


def unit_cell_curve(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    travel: float | None = None,
    n_elements: int | None = None,
    max_steps: int = 3000,
    step: float | None = None,
    grading: float = 0.0,
    plate: Plate | None = None,
) -> UnitCellRun:
    """Trace one dome unit's equilibrium path under apex displacement control.

    Parameters
    ----------
    H, t, r_b : float, mm
        Dome height, thickness and base radius (mid-surface; MODEL.md §2).
    E : float, MPa
        Young's modulus (linear elastic).
    nu : float
        Poisson ratio.
    travel : float, mm, optional
        Apex travel at which the trace stops (default ``2.2 H``, past the inverted state;
        ``2.5 H`` with a ``plate``).
    n_elements : int, optional
        Segments along the meridian (default :data:`DEFAULT_ELEMENTS`).
    max_steps : int
        Most continuation steps.
    step : float, mm, optional
        Largest continuation step in the weighted arclength (default ``travel / 60``).
    grading : float
        Mesh grading toward the apex, in ``[0, 0.9]`` (:mod:`.geometry`); 0 is uniform.
    plate : Plate, optional
        Set the cap in the unit cell's plate (:class:`~.geometry.Plate`); default: the cap
        pinned at ``r_b``, as the paper's unit-cell runs.

    Returns
    -------
    UnitCellRun
        The path; ``status`` says whether it reached ``travel`` (the solver reports, it does not
        raise).

    Raises
    ------
    ValueError
        One line naming the first bad parameter.
    """
    H, t, r_b, E, nu = check_inputs(H, t, r_b, E, nu)
    n = _elements(n_elements)
    grading = _grading(grading)
    if travel is None:
        travel = (DEFAULT_TRAVEL if plate is None else PLATE_TRAVEL) * H
    else:
        travel = _positive("travel", travel)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
        raise ValueError(f"max_steps={max_steps!r}: must be a positive integer")
    h_max = DEFAULT_STEP * travel if step is None else _positive("step", step)
    plate = None if plate is None else plate.checked(r_b)
    geom = shell(H, t, r_b, E, nu, n, grading, plate)
    check_path_size(geom.r0.size - 1, max_steps)
    ftol, xtol = _tolerances(H, t, E)
    _announce()
    started = time.perf_counter()
    trace = (geom, travel, h_max, max_steps, ftol, xtol)
    main = _trace(*trace, reference_unknowns(geom), 1.0, False)
    pieces = [main]
    name = _STATUS[main.status]
    message = _MESSAGES[name]
    if main.force.size == 0:  # not even the start: nothing to follow or mirror
        name = "no_path"
        message = _MESSAGES[name]
    elif name != "reached":
        inverted = _inverted_branch(*trace, H)
        if inverted is not None:
            pieces.append(inverted)
            name, message = "partial", _partial_message(name)
    ys = np.concatenate([p.ys for p in pieces])
    ts = np.concatenate([p.ts for p in pieces])
    force = np.concatenate([p.force for p in pieces])
    energy = np.concatenate([p.energy for p in pieces])
    index = np.concatenate([p.index for p in pieces])
    slope = np.concatenate([p.slope for p in pieces])
    branch, work, zero = [], [], []
    for piece in pieces:
        if piece.force.size == 0:  # the no_path run: empty arrays throughout
            branch.append(np.zeros(0, dtype=np.int64))
            work.append(np.zeros(0))
            continue
        ids = branch_ids(piece.ts[:, 0]) + (branch[-1][-1] + 1 if branch else 0)
        branch.append(ids)
        work.append(work_along_path(piece.ys, piece.ts, piece.force, piece.slope))
        work[-1] += piece.energy[0].sum()
        zero.extend(
            find_zero_force_states(geom, piece.ys, piece.force, ids, piece.index, ftol, xtol)
        )
    branch, work = np.concatenate(branch), np.concatenate(work)
    count = force.size
    n_all = geom.r0.size - 1  # the cap's segments and the plate's
    shapes = np.empty((count, n_all + 1, 2))
    r, z = np.empty(n_all + 1), np.empty(n_all + 1)
    for i in range(count):
        nodes(ys[i], geom, r, z)
        shapes[i, :, 0], shapes[i, :, 1] = r, z
    steps = np.diff(ys, axis=0) if count else ys
    weighted = np.sqrt(steps[:, 0] ** 2 + np.sum(steps[:, 1:] ** 2, axis=1) / (n_all - 1))
    rests = [s for s in zero if s.stable and s.displacement > H]
    ghost, tip, tip_kind = None, None, None
    if rests:
        tip, tip_kind = min(rests, key=lambda s: s.energy).displacement, "rest"
    elif count:
        with np.errstate(divide="ignore", invalid="ignore"):
            stiffness = slope / ts[:, 0]
        path = PathSamples(ys[:, 0], force, stiffness, index == 0, branch)
        stepped = find_stepped_over_rests(path, H)  # a rest next to the saddle-node, between points
        if stepped:
            tip, tip_kind = stepped[0], "rest"
        else:
            ghost = find_ghost(path, H)
            tip, tip_kind = (ghost.displacement, "ghost") if ghost else (None, None)
    return UnitCellRun(
        H=H,
        t=t,
        r_b=r_b,
        E=E,
        nu=nu,
        n_elements=n,
        displacement=ys[:, 0].copy(),
        force=force,
        energy=energy.sum(axis=1),
        membrane_energy=energy[:, 0].copy(),
        bending_energy=energy[:, 1].copy(),
        stable=index == 0,
        instability_index=index,
        branch=branch,
        shapes=shapes,
        arclength=np.concatenate([[0.0], np.cumsum(weighted)])[:count],
        work=work,
        initial_stiffness=main.stiffness,
        zero_force_states=tuple(zero),
        tip_dis=tip,
        tip_kind=tip_kind,
        status=name,
        message=message,
        elapsed=time.perf_counter() - started,
        tangents=ts,
        gap=main.force.size - 1 if len(pieces) > 1 else None,
        ghost=ghost,
        plate=plate,
    )


@dataclass(frozen=True)
class _Piece:
    """A connected stretch of the path (arrays trimmed to its points)."""

    status: int
    ys: NDArray
    ts: NDArray
    energy: NDArray
    force: NDArray
    slope: NDArray
    index: NDArray

    @property
    def stiffness(self) -> float:
        return float(self.slope[0] / self.ts[0, 0]) if self.force.size else math.nan

    def reversed(self) -> _Piece:
        """The same stretch walked the other way (tangents and slopes change sign)."""
        return _Piece(
            self.status,
            self.ys[::-1],
            -self.ts[::-1],
            self.energy[::-1],
            self.force[::-1],
            -self.slope[::-1],
            self.index[::-1],
        )


def _trace(geom, travel, h_max, max_steps, ftol, xtol, y0, direction, stop_at_fold) -> _Piece:
    # fixed scalar types: one record type, one compiled signature
    controls = PathControls(
        h0=float(0.25 * h_max),
        h_max=float(h_max),
        h_min=float(1e-8 * h_max),
        max_steps=int(max_steps),
        ftol=float(ftol),
        xtol=float(xtol),
    )
    status, count, points = shell_path.follow(
        geom, y0, float(travel), controls, float(direction), bool(stop_at_fold)
    )
    # copies: the kernel's arrays hold max_steps + 1 points, a view would keep them all alive
    return _Piece(int(status), *(a[:count].copy() for a in points))


def _inverted_branch(geom, travel, h_max, max_steps, ftol, xtol, H) -> _Piece | None:
    """The inverted branch traced from the dome's mirror image, when the path did not get there.

    The mirror image through the base plane (apex travel ``2 H``) is relaxed with the apex free
    to the inverted zero-force state; from there the branch is followed down in travel to its
    fold and up to ``travel``, and returned in increasing path order (fold first).
    """
    y = reference_unknowns(geom)
    y[2::2] *= -1.0
    y[0] = 2.0 * H
    shell_path.relax(y, geom, True, ftol, 300)
    # relax stalls at round-off on fine meshes: Newton polishes (and judges) what it reached
    its, index = shell_path.equilibrate_free(y, geom, ftol, xtol)
    if its < 0 or index != 0 or y[0] <= H:
        return None
    down = _trace(geom, travel, h_max, max_steps, ftol, xtol, y, -1.0, True).reversed()
    up = _trace(geom, travel, h_max, max_steps, ftol, xtol, y, 1.0, False)
    if down.force.size == 0 or up.force.size == 0:
        return None
    return _Piece(
        up.status,
        *(
            np.concatenate([a, b[1:]])
            for a, b in zip(
                (down.ys, down.ts, down.energy, down.force, down.slope, down.index),
                (up.ys, up.ts, up.energy, up.force, up.slope, up.index),
                strict=True,
            )
        ),
    )


def apex_stiffness(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    n_elements: int | None = None,
    grading: float = 0.0,
    plate: Plate | None = None,
) -> float:
    """Small-deflection apex stiffness ``dF/dδ`` (N/mm) of the undeformed dome.

    ``H = 0`` is allowed: the pinned circular plate. Same discretisation (and ``plate``) as
    :func:`unit_cell_curve`.
    """
    H, t, r_b, E, nu = check_inputs(H, t, r_b, E, nu, allow_flat=True)
    plate = None if plate is None else plate.checked(r_b)
    geom = shell(H, t, r_b, E, nu, _elements(n_elements), _grading(grading), plate)
    ftol, xtol = _tolerances(max(H, t), t, E)
    _announce()
    return _trace(geom, 1.0, 0.01, 0, ftol, xtol, reference_unknowns(geom), 1.0, False).stiffness
