"""A dome inverting against its neighbour's chamber wall: the two-unit run, axisymmetric.

The paper took the reach ``d`` of its lattice (MODEL.md §3, §11) from runs of two consecutive
units with contact: the final apex travel ``tip_dis`` of a dome that inverted against the next
unit. :func:`two_unit_rest` is that run at the fidelity of the axisymmetric shell
(:mod:`dpfexplore._kernels.shell`): the dome (in its unit cell's plate, :class:`~.geometry.Plate`,
or pinned at ``r_b``), inverted and resting with no apex load, against a flat wall across its
axis at ``gap`` beyond its base plane (mid-surface), the wall's face being the neighbour's
chamber wall (``gap = U_sep + t_ch/2`` in a finger, MODEL.md §2). Contact is a stiff penalty
(:mod:`dpfexplore._kernels.shell.contact`), the dome's facing surface ``t/2`` below its
mid-surface. The wall is rigid, or it gives way as a piston on a spring of
``wall_stiffness`` (N/mm): the neighbour rotating about the limiting layer, its face bending.

What the axisymmetric run cannot represent: in a finger the neighbour's wall tilts as the
units rotate apart about the limiting layer, so the contact is off the dome's axis and the
dome is pushed sideways as well as back; the chamber's square face and side walls (the plate
is an annulus); a 3-D (non-axisymmetric) inversion; friction; the pressure that inverted the
dome (the run rests with the pressure released); and the neighbour's own dome.

It starts from the dome's free inverted rest (the stable zero-force state past ``H`` on its path
under apex displacement control, as :func:`~.shell.unit_cell_curve` finds it), so with the wall
beyond that rest's reach it returns the rest exactly: the free dome. Otherwise the wall comes in
from where it touches the free rest, in small steps, each rest found from the last (the
neighbour meeting the inverting dome): a wall that pushes the dome back over its barrier leaves
it resting by itself off the wall (``touching`` True, ``reaction`` 0, ``tip_dis`` that state's
travel, near 0).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from .._kernels.shell import contact as shell_contact
from .._kernels.shell import path as shell_path
from .._kernels.shell.energy import BAND, nodes
from .._kernels.shell.records import Wall
from ..solvers.compilation import announce
from .geometry import Plate, check_inputs, reference_unknowns, shell
from .shell import DEFAULT_STEP, _announce, _elements, _tolerances, _trace

__all__ = ["CONTACT_MODULUS", "ContactRest", "two_unit_rest"]

#: The penalty's modulus in units of ``E / t``: a layer ``t / CONTACT_MODULUS`` thick of the
#: dome's own material (doubling it moves ``tip_dis`` by < 1e-4 relative:
#: ``tests/unitcell/test_contact.py``).
CONTACT_MODULUS = 1e3
#: Most Newton iterations of one relaxation against the wall (Newton polishes after it).
RELAX_ITER = 40
#: Most iterations of the relaxation of a dome pushed off the wall, to its own rest.
LEAVE_ITER = 2000
#: Largest step of the wall coming in, in dome heights.
MARCH = 0.02
#: Apex travel, in dome heights, to which the path is traced for the free rest.
TRAVEL = 2.4


@dataclass(frozen=True)
class ContactRest:
    """The dome's inverted rest against its neighbour's wall.

    Attributes
    ----------
    tip_dis : float or None, mm
        Apex travel (mid-surface, from the undeformed dome) at the rest with the wall; None
        when the dome has no inverted rest (it springs back without the pressure).
    free_tip_dis : float or None, mm
        The same without the wall (the free inverted rest).
    touching : bool
        The free rest reaches through the wall's plane, so the wall holds the dome back.
    reaction : float, N
        The wall's push on the dome at the rest (0 when not touching).
    wall_travel : float, mm
        How far the wall gave way (``reaction / wall_stiffness``; 0 for a rigid wall).
    stable : bool
        The rest is a minimum with the wall (full Hessian positive definite).
    energy : float, N·mm
        The dome's strain energy at the rest (the wall's penalty excluded).
    shape : ndarray (n_nodes, 2), mm
        The deformed meridian ``(r, z)`` at the rest, apex first.
    elapsed : float, s
    """

    tip_dis: float | None
    free_tip_dis: float | None
    touching: bool
    reaction: float
    wall_travel: float
    stable: bool
    energy: float
    shape: NDArray
    elapsed: float


_ANNOUNCED: list[bool] = []


def _announce_contact() -> None:
    """Once per process: say that the contact kernels compile (first run only), then load them.

    A tiny run compiles (or loads from Numba's cache) every kernel the wall calls, so that
    :attr:`ContactRest.elapsed` is run time only.
    """
    if _ANNOUNCED:
        return
    _ANNOUNCED.append(True)
    announce(["unit-cell contact"])
    geom = shell(1.0, 0.1, 2.0, 1.0, 0.3, 4)
    y = reference_unknowns(geom)
    wall = Wall(-0.5, 0.05, 1.0, np.ones(geom.r0.size))
    shell_contact.rest_on_wall(y.copy(), geom, wall, 1e-9, 1)
    shell_contact.polish_on_wall(y.copy(), geom, wall, 1e-9, 1e-12)
    shell_contact.wall_energy(y, geom, wall, np.zeros(0), np.zeros((0, 0)), 0)
    band = np.zeros((y.size, 2 * BAND + 1))
    shell_contact.assemble_wall(y, geom, wall, np.zeros(y.size), band, 2)


def _contact_area(r0: NDArray, z0: NDArray) -> NDArray:
    """Each node's share of the reference surface (mm²): between its segments' midpoints."""
    l0 = np.hypot(np.diff(r0), np.diff(z0))
    rm0 = 0.5 * (r0[:-1] + r0[1:])
    area = np.zeros(r0.size)
    area[:-1] += 0.5 * math.pi * (r0[:-1] + rm0) * l0
    area[1:] += 0.5 * math.pi * (rm0 + r0[1:]) * l0
    return area


def _shape(y: NDArray, geom) -> NDArray:
    n = geom.r0.size
    r, z = np.empty(n), np.empty(n)
    nodes(y, geom, r, z)
    return np.column_stack([r, z])


def two_unit_rest(
    H: float,
    t: float,
    r_b: float = 5.0,
    E: float = 26.0,
    nu: float = 0.35,
    *,
    gap: float,
    wall_stiffness: float = math.inf,
    plate: Plate | None = None,
    n_elements: int | None = None,
) -> ContactRest:
    """The inverted rest of one dome against its neighbour's wall (module docstring).

    Parameters
    ----------
    H, t, r_b : float, mm
        Dome height, thickness and base radius (mid-surface).
    E : float, MPa
    nu : float
    gap : float, mm
        From the dome's base plane (mid-surface) to the wall's face, on the inverted side
        (``U_sep + t_ch/2`` in a finger); ``math.inf`` for no wall.
    wall_stiffness : float, N/mm
        The wall's give (a piston on a spring); ``math.inf``: rigid.
    plate : Plate, optional
        The unit cell's plate around the cap (:class:`~.geometry.Plate`); default pinned cap.
    n_elements : int, optional
        Segments of the cap's meridian (default as :func:`~.shell.unit_cell_curve`).

    Returns
    -------
    ContactRest
    """
    H, t, r_b, E, nu = check_inputs(H, t, r_b, E, nu)
    if isinstance(gap, bool) or not isinstance(gap, int | float) or math.isnan(gap) or gap < 0:
        raise ValueError(f"gap={gap!r}: must be a number >= 0 (mm), or inf for no wall")
    if not isinstance(wall_stiffness, int | float) or not wall_stiffness > 0:
        raise ValueError(f"wall_stiffness={wall_stiffness!r}: must be > 0 (N/mm) or inf")
    plate = None if plate is None else plate.checked(r_b)
    geom = shell(H, t, r_b, E, nu, _elements(n_elements), 0.0, plate)
    ftol, xtol = _tolerances(H, t, E)
    _announce()
    _announce_contact()
    started = time.perf_counter()
    y = _free_rest(geom, H, ftol, xtol)
    if y is None:
        y = reference_unknowns(geom)
        return ContactRest(
            None,
            None,
            False,
            0.0,
            0.0,
            False,
            0.0,
            _shape(y, geom),
            time.perf_counter() - started,
        )
    free = float(y[0])
    shape = _shape(y, geom)
    offset = 0.5 * t
    # how far the wall would have to give way to clear the free rest (<= 0: it does)
    clear = -gap - (float(np.min(shape[:-1, 1])) - offset)
    if not math.isfinite(gap) or clear <= 0.0:
        membrane, bending = _energy(y, geom)
        return ContactRest(
            free,
            free,
            False,
            0.0,
            0.0,
            True,
            membrane + bending,
            shape,
            time.perf_counter() - started,
        )
    area = _contact_area(geom.r0, geom.z0)
    modulus = CONTACT_MODULUS * E / t

    def wall_at(shift: float) -> Wall:
        """The wall moved ``shift`` (mm) away from where the finger's gap puts it."""
        return Wall(float(-gap - shift), float(offset), float(modulus), area)

    def settle(state: NDArray, shift: float) -> tuple[float, int]:
        """Rest ``state`` (in place) against the wall moved ``shift`` (mm) away; reaction."""
        wall = wall_at(shift)
        relaxed = state.copy()
        shell_contact.rest_on_wall(relaxed, geom, wall, ftol, RELAX_ITER)
        state[:] = relaxed
        its, negative = shell_contact.polish_on_wall(state, geom, wall, ftol, xtol)
        if its < 0:  # Newton did not settle: keep the relaxed state, judged there
            state[:] = relaxed
            negative = _inertia(state, geom, wall)
        none = np.zeros(0)
        reaction = shell_contact.wall_energy(state, geom, wall, none, np.zeros((0, 0)), 0)[1]
        return float(reaction), int(negative)

    # the wall comes in from where it touches the free rest, in steps of MARCH · H, as the
    # neighbour does when the dome inverts against it: the dome is followed, not jumped
    steps = max(1, math.ceil(clear / (MARCH * H)))
    shifts = np.linspace(clear, 0.0, steps + 1)[1:]
    previous, reaction, negative = clear, 0.0, 0
    for shift in shifts:
        before = y.copy()
        reaction, negative = settle(y, float(shift))
        if reaction == 0.0:  # the dome left the wall, pushed back over its barrier: its rest
            reaction, negative = _leave_wall(y, geom, wall_at(shift), ftol, xtol)
            break
        if math.isfinite(wall_stiffness) and reaction >= wall_stiffness * shift:
            # the spring carries the push somewhere in this step: the wall rests there
            def balance(s: float, start: NDArray = before) -> float:
                trial = start.copy()
                return settle(trial, s)[0] - wall_stiffness * s

            shift = brentq(balance, float(shift), previous, xtol=1e-9 * H)
            y = before
            reaction, negative = settle(y, float(shift))
            if negative > 0:  # balanced past the dome's fold: it goes back over its barrier
                reaction, negative = _leave_wall(y, geom, wall_at(shift), ftol, xtol)
            break
        previous = float(shift)
    membrane, bending = _energy(y, geom)
    return ContactRest(
        tip_dis=float(y[0]),
        free_tip_dis=free,
        touching=True,
        reaction=reaction,
        wall_travel=float(shift),
        stable=negative == 0,
        energy=membrane + bending,
        shape=_shape(y, geom),
        elapsed=time.perf_counter() - started,
    )


def _leave_wall(y: NDArray, geom, wall: Wall, ftol: float, xtol: float) -> tuple[float, int]:
    """Relax ``y`` (in place) to the dome's own rest beside ``wall``; its reaction and index.

    For a dome pushed back over its barrier (the wall's step leaves it no contact, or the
    spring's balance lies past the dome's fold, an unstable state): the rest on the other side.
    """
    shell_contact.rest_on_wall(y, geom, wall, ftol, LEAVE_ITER)
    negative = int(shell_contact.polish_on_wall(y, geom, wall, ftol, xtol)[1])
    reaction = shell_contact.wall_energy(y, geom, wall, np.zeros(0), np.zeros((0, 0)), 0)[1]
    return float(reaction), negative


def _free_rest(geom, H: float, ftol: float, xtol: float) -> NDArray | None:
    """The stable zero-force inverted state, found as :func:`~.shell.unit_cell_curve` does.

    The path under apex displacement control is traced to ``TRAVEL · H``; every rise of the
    force through zero past ``H`` is refined by Newton with the apex free, and the stable one
    of least energy is returned (None if there is none).
    """
    travel = TRAVEL * H
    piece = _trace(
        geom, travel, DEFAULT_STEP * travel, 3000, ftol, xtol, reference_unknowns(geom), 1.0, False
    )
    best, lowest = None, math.inf
    force, ys = piece.force, piece.ys
    for i in range(1, force.size):
        if not (force[i - 1] < 0.0 <= force[i] and ys[i, 0] > H):
            continue
        f = force[i - 1] / (force[i - 1] - force[i])
        y = (1.0 - f) * ys[i - 1] + f * ys[i]
        its, index = shell_path.equilibrate_free(y, geom, ftol, xtol)
        if its >= 0 and index == 0 and y[0] > H:
            energy = sum(_energy(y, geom))
            if energy < lowest:
                best, lowest = y, energy
    return best


def _inertia(y: NDArray, geom, wall: Wall) -> int:
    """Negative eigenvalues of the Hessian with the wall at ``y`` (-1: singular)."""
    from .._kernels.linalg.band_storage import negative_pivots

    band = np.zeros((y.size, 2 * BAND + 1))
    shell_contact.assemble_wall(y, geom, wall, np.zeros(y.size), band, 2)
    return int(negative_pivots(band, 0, BAND, np.zeros_like(band)))


def _energy(y: NDArray, geom) -> tuple[float, float]:
    from .._kernels.shell.energy import assemble

    membrane, bending = assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)
    return float(membrane), float(bending)
