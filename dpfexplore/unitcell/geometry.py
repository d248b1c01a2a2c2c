"""The discretised dome: inputs checked once, the reference meridian, the kernels' geometry.

A dome unit is a spherical cap of base radius ``r_b``, height ``H`` and radius
``R = (r_b² + H²) / (2 H)`` (MODEL.md §2), all of its mid-surface. Its meridian is cut into
``n_elements`` straight segments between nodes at polar angles ``φ_k = φ_b ξ_k`` from the apex
(``φ_b = 2 atan(H / r_b)``, so deep caps beyond the hemisphere are covered too), with
``ξ_k = (1 - c) k/N + c (k/N)²``: ``grading = c`` in ``[0, 0.9]`` makes the elements next to the
apex ``(1 - c)/(1 + c)`` times the size of those at the edge (for the point-load checks; the
inversion's ridge sweeps the whole meridian, so the curves use a uniform mesh).
``H = 0`` gives the flat plate (only for :func:`~dpfexplore.unitcell.shell.apex_stiffness`).

**The unit cell's plate.** The dome sits in a face of its chamber, a flat square plate of side
``UC = 3 r_b`` (MODEL.md §2) and thickness ``t_ch``. A :class:`Plate` sets the cap in an
axisymmetric annulus of that thickness from ``r_b`` to an outer radius (the square's
area-equivalent ``UC/√π`` by :func:`square_plate`), its outer edge pinned or clamped (the side
walls of the chamber hold it somewhere between the two). The annulus is meshed at the cap's
element size; a segment's thickness enters the kernels through its weights (membrane
``∝ t_j``, bending ``∝ t_j³``, :class:`~dpfexplore._kernels.shell.records.ShellGeometry` keeps
the cap's ``C`` and ``D``). A clamped edge is a rotational spring :data:`CLAMP` times the edge
node's own bending stiffness on the last segment's slope. What an annulus cannot represent: the
square's corners (its bending is not axisymmetric) and the chamber's side walls, whose rotation
would make the edge elastic.

**Sizes.** The path kernel allocates its points for every allowed step before the first
(:func:`path_bytes`); :func:`check_path_size` refuses a ``max_steps`` whose arrays would pass
:data:`MAX_PATH_BYTES`, before anything is allocated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real

import numpy as np

from .._kernels.shell.records import ShellGeometry

__all__ = [
    "CLAMP",
    "EDGES",
    "MAX_PATH_BYTES",
    "WALL_PER_RADIUS",
    "Plate",
    "cell_plate",
    "check_inputs",
    "check_path_size",
    "n_unknowns",
    "path_bytes",
    "plate_elements",
    "reference_meridian",
    "reference_unknowns",
    "shell",
    "square_plate",
]

#: Outer-edge conditions of a :class:`Plate`.
EDGES = ("pinned", "clamped")
#: A clamped edge's rotational spring, in units of the edge node's bending stiffness
#: ``4 A_N D / ℓ²`` (a ghost segment's): large enough that the slope moves by ~1e-4 of a
#: pinned edge's, small enough to keep the banded factorisation well conditioned.
CLAMP = 1e4


@dataclass(frozen=True)
class Plate:
    """The flat plate of the unit cell around the dome: an annulus ``r_b < r <= radius``.

    Attributes
    ----------
    radius : float, mm
        Outer radius (the square face's area-equivalent radius ``UC/√π``: :func:`square_plate`).
        Equal to ``r_b``: no annulus (the cap alone, with this edge).
    thickness : float, mm
        Plate thickness (the chamber wall's ``t_ch``).
    edge : str
        Outer edge ``"pinned"`` (position fixed, rotation free) or ``"clamped"``.
    """

    radius: float
    thickness: float = 1.0
    edge: str = "pinned"

    def checked(self, r_b: float) -> Plate:
        """The plate with its fields checked against the dome's ``r_b``; ``ValueError``."""
        radius = _number("plate radius", self.radius, low=r_b, low_open=False)
        thickness = _number("plate thickness", self.thickness, low=0.0)
        if self.edge not in EDGES:
            raise ValueError(f"plate edge={self.edge!r}: must be one of {', '.join(EDGES)}")
        if thickness >= radius:
            raise ValueError(f"plate thickness={thickness!r}: must be below its radius")
        return Plate(radius, thickness, self.edge)


#: The chamber wall's thickness per base radius in the paper's unit cell (``t_ch = 1`` mm at
#: ``r_b = 5`` mm, MODEL.md §2).
WALL_PER_RADIUS = 0.2


def cell_plate(r_b: float) -> Plate:
    """The paper's unit cell's plate scaled with ``r_b``: :func:`square_plate` of ``t_ch = r_b/5``.

    At ``r_b = 5`` mm this is the face of the paper's cell (``UC = 15``, ``t_ch = 1`` mm); a
    dome of another base radius sits in the geometrically similar cell, so that the reach per
    height depends on ``t/H`` and ``H/R`` alone, as the closed forms assume.
    """
    return square_plate(r_b, WALL_PER_RADIUS * r_b, "pinned")


def square_plate(r_b: float = 5.0, t_ch: float = 1.0, edge: str = "pinned") -> Plate:
    """The unit cell's square face (side ``UC = 3 r_b``) as the annulus of equal area.

    Outer radius ``3 r_b / √π`` (8.46 mm for ``r_b = 5``), thickness ``t_ch`` (mm).
    """
    return Plate(3.0 * r_b / math.sqrt(math.pi), t_ch, edge)


def _number(name: str, value, *, low: float, high: float = math.inf, low_open=True) -> float:
    if isinstance(value, bool) or not isinstance(value, Real | np.floating | np.integer):
        raise ValueError(f"{name}={value!r}: must be a number")
    value = float(value)
    below = value <= low if low_open else value < low
    if not math.isfinite(value) or below or value >= high:
        bound = f"> {low:g}" if low_open else f">= {low:g}"
        upper = f" and < {high:g}" if math.isfinite(high) else ""
        raise ValueError(f"{name}={value!r}: must be finite, {bound}{upper}")
    return value


def check_inputs(H, t, r_b, E, nu, *, allow_flat: bool = False) -> tuple[float, ...]:
    """``(H, t, r_b, E, nu)`` as floats; ``ValueError`` naming the first bad parameter.

    ``H`` (mm) > 0 (>= 0 with ``allow_flat``), ``t`` (mm) > 0 and below the smaller of ``r_b``
    and ``R`` (a shell), ``r_b`` (mm) > 0, ``E`` (MPa) > 0, ``-1 < nu < 0.5``.
    """
    H = _number("H", H, low=0.0, low_open=not allow_flat)
    t = _number("t", t, low=0.0)
    r_b = _number("r_b", r_b, low=0.0)
    E = _number("E", E, low=0.0)
    nu = _number("nu", nu, low=-1.0, high=0.5)
    R = (r_b**2 + H**2) / (2.0 * H) if H > 0 else math.inf
    if t >= min(r_b, R):
        raise ValueError(
            f"t={t!r}: must be smaller than r_b ({r_b:g}) and R ({R:.4g}) to be a shell"
        )
    return H, t, r_b, E, nu


def reference_meridian(H: float, r_b: float, n_elements: int, grading: float = 0.0):
    """Node coordinates ``(r0, z0)`` (mm, ``n_elements + 1`` each) of the undeformed meridian."""
    k = np.arange(n_elements + 1) / n_elements
    xi = (1.0 - grading) * k + grading * k * k
    if H == 0.0:
        return r_b * xi, np.zeros_like(xi)
    R = (r_b**2 + H**2) / (2.0 * H)
    phi = 2.0 * math.atan(H / r_b) * xi
    r0 = R * np.sin(phi)
    z0 = H - 2.0 * R * np.sin(0.5 * phi) ** 2  # = R cos φ - (R - H) without the cancellation
    r0[-1], z0[-1] = r_b, 0.0
    r0[0], z0[0] = 0.0, H
    return r0, z0


def plate_elements(H: float, r_b: float, n_elements: int, plate: Plate | None) -> int:
    """Segments of the annulus: the plate's width at the cap's mean element size."""
    if plate is None or plate.radius <= r_b:
        return 0
    arc = 2.0 * math.atan(H / r_b) * (r_b**2 + H**2) / (2.0 * H) if H > 0 else r_b
    return max(2, round(n_elements * (plate.radius - r_b) / arc))


def shell(
    H: float,
    t: float,
    r_b: float,
    E: float,
    nu: float,
    n_elements: int,
    grading: float = 0.0,
    plate: Plate | None = None,
) -> ShellGeometry:
    """The kernels' :class:`~dpfexplore._kernels.shell.records.ShellGeometry` of one dome.

    Every reference quantity is that of the polygon itself (chord lengths, chord slopes,
    frustum areas), so the discrete reference state is exactly strain-free. With a ``plate``,
    the cap's ``n_elements`` segments are followed by :func:`plate_elements` of the annulus
    (module docstring); without, the edge is pinned at ``r_b``.
    """
    r0, z0 = reference_meridian(H, r_b, n_elements, grading)
    n_ring = plate_elements(H, r_b, n_elements, plate)
    thick = None
    if n_ring:
        r0 = np.concatenate([r0, np.linspace(r_b, plate.radius, n_ring + 1)[1:]])
        z0 = np.concatenate([z0, np.zeros(n_ring)])
        thick = np.concatenate([np.full(n_elements, t), np.full(n_ring, plate.thickness)])
    n_all = n_elements + n_ring
    dr, dz = np.diff(r0), np.diff(z0)
    l0 = np.hypot(dr, dz)
    a0 = np.arctan2(-dz, dr)
    rm0 = 0.5 * (r0[:-1] + r0[1:])
    wm = 2.0 * math.pi * rm0 * l0
    # each node carries the frustum between it and the midpoints of its segments
    half_in = 0.5 * math.pi * (r0[:-1] + rm0) * l0
    half_out = 0.5 * math.pi * (rm0 + r0[1:]) * l0
    if thick is not None:  # the plate's thickness through the weights (module docstring)
        wm = wm * (thick / t)
        half_in, half_out = half_in * (thick / t) ** 3, half_out * (thick / t) ** 3
    area = np.zeros(n_all + 1)
    area[:-1] += half_in
    area[1:] += half_out
    s0 = np.empty(n_all + 1)
    s0[0], s0[-1] = l0[0], l0[-1]
    s0[1:-1] = 0.5 * (l0[:-1] + l0[1:])
    beta0 = np.zeros(n_all + 1)
    beta0[1:-1] = np.diff(a0)
    sa0 = np.zeros(n_all + 1)
    sa0[1:-1] = np.sin(a0[:-1] + 0.5 * beta0[1:-1])
    C = E * t / (1.0 - nu**2)
    D = E * t**3 / (12.0 * (1.0 - nu**2))
    k_edge = 0.0
    if plate is not None and plate.edge == "clamped":
        k_edge = CLAMP * 4.0 * area[-1] * D / l0[-1] ** 2
    return ShellGeometry(r0, z0, l0, a0, rm0, wm, area, s0, beta0, sa0, C, D, nu, k_edge)


def n_unknowns(n_elements: int) -> int:
    """Length of the unknown vector: apex travel and ``(r, z)`` of the free nodes."""
    return 2 * n_elements - 1


def reference_unknowns(geom: ShellGeometry) -> np.ndarray:
    """The unknowns of the undeformed dome (``δ = 0``)."""
    n = geom.r0.shape[0] - 1
    y = np.zeros(n_unknowns(n))
    y[1::2] = geom.r0[1:n]
    y[2::2] = geom.z0[1:n]
    return y


#: Most bytes the arrays of one traced stretch may take: the path kernel allocates its points
#: for ``max_steps`` steps before the first one (:func:`path_bytes`). 2 GiB holds over 500,000
#: steps at the default 128 elements; a simple dome takes 150-250.
MAX_PATH_BYTES = 2 << 30


def path_bytes(n_segments: int, max_steps: int) -> int:
    """Bytes the kernel allocates for one traced stretch: ``max_steps + 1`` points.

    Each point holds the unknowns and the tangent (``m = 2 n_segments - 1`` each), two energies,
    the force, its slope and the instability index: ``8 (2 m + 5)`` bytes.
    """
    m = 2 * int(n_segments) - 1
    return 8 * (int(max_steps) + 1) * (2 * m + 5)


def check_path_size(n_segments: int, max_steps: int, label: str | None = None) -> None:
    """Refuse a ``max_steps`` whose arrays exceed :data:`MAX_PATH_BYTES`, before any allocation.

    Parameters
    ----------
    n_segments : int
        Segments of the meridian (the cap's, and the plate's if any).
    max_steps : int
        Most continuation steps.
    label : str, optional
        How the message starts (default ``max_steps=N``; ``options.max_steps = N`` for a job
        file).

    Raises
    ------
    ValueError
        ``max_steps=N: the path's arrays would take X GB at K elements, more than the Y GB
        allowed; give at most M``.
    """
    need = path_bytes(n_segments, max_steps)
    if need > MAX_PATH_BYTES:
        most = MAX_PATH_BYTES // path_bytes(n_segments, 0) - 1
        raise ValueError(
            f"{label or f'max_steps={max_steps}'}: the path's arrays would take "
            f"{need / 1e9:.4g} GB at {n_segments} elements, more than the "
            f"{MAX_PATH_BYTES / 1e9:.3g} GB allowed; give at most {most}"
        )
