"""Object classes for the sorting loop: how far each class sits from the loop's boundaries.

A class is a name, a diameter range ``[d_lo, d_hi]`` (mm) and a mass range ``[m_lo, m_hi]``
(kg): a box in the sorting map's plane. The loop (:func:`~.sort.run_sort`, the batch kernel)
classifies a class correctly when every object of its box gets the outcome of the box's centre,
that outcome is sized and held (``light`` or ``heavy``), and no other class gets it.

Margin of a class, from the loop itself (no proxy):

* **Diameter margin** (mm): ``min(d_lo - L, U - d_hi)``, where ``[L, U]`` is the widest
  interval of diameters around the box's centre over which every mass of the class's range
  gets the centre's outcome (the same size state and weight class): the horizontal distance
  of the box from the nearest boundary, a size boundary or a weight boundary (the diameter
  where a state is lost to a wider object, or its payload passes the class's mass). Boundaries
  are located on a grid of ``step`` mm from half the smallest class's lower diameter to the
  open gripper's aperture (an object wider does not fit: a boundary) and refined by bisection
  on the loop to ``tol`` mm. A class whose centre does not get one outcome for its whole mass
  range, is not sized, or whose outcome another class shares, gets ``-(d_hi - d_lo) / 2``:
  the value a boundary through its centre gives.
* **Mass margin** (kg): the vertical distance of the box from the weight boundaries, the worst
  over the box's diameters (the grid's within the box and its two ends): with ``P(D)`` and
  ``T(D)`` the payloads (kg) of the deciding state without and with the tip unit inverted
  (``T = 0`` when the tip unit resets before the lift ends), ``light``: ``min P - m_hi``;
  ``heavy``: ``min(m_lo - max P, min T - m_hi)``; ``not_held`` at the centre:
  ``min max(P, T) - m_hi`` (negative), and then the diameter margin is at most minus half the
  box's width minus the distance from its centre to the nearest diameter where the loop holds
  ``m_hi`` (so that a class not held still has a margin that grows as a boundary comes near).
* **Margin**: ``min(diameter / diameter_scale, mass / mass_scale)``, dimensionless; a design's
  margin is the smallest of its classes'. Positive: every class is classified correctly, by at
  least that many scales of diameter or mass.

Boundaries narrower than ``step`` can pass between two grid points unseen: the re-verification
by :func:`~.sort.sort_objects` on :func:`class_samples` is the check that does not rely on the
grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .setup import GRAVITY, GraspOptions, Gripper
from .sort import WEIGHT_CLASSES, Objects, run_sort

__all__ = [
    "ClassMargin",
    "ObjectClass",
    "SortingMargins",
    "class_margins",
    "class_samples",
]


@dataclass(frozen=True)
class ObjectClass:
    """A class of objects: a box of diameters (mm) and masses (kg).

    Attributes
    ----------
    name : str
    diameter : (low, high), mm
    mass : (low, high), kg
    """

    name: str
    diameter: tuple[float, float]
    mass: tuple[float, float]

    @property
    def centre(self) -> tuple[float, float]:
        """The box's centre (mm, kg)."""
        return 0.5 * (self.diameter[0] + self.diameter[1]), 0.5 * (self.mass[0] + self.mass[1])


@dataclass(frozen=True)
class ClassMargin:
    """One class's place in the sorting map (units in the names).

    Attributes
    ----------
    name : str
    label : str
        The loop's outcome at the box's centre, ``SIZE/WEIGHT`` (``none`` for no size).
    interval_mm : (L, U)
        The diameters around the centre where the class's masses get its outcome (NaN: none).
    size_margin_mm : float
        The diameter margin (mm).
    mass_margin_kg : float
    margin : float
        ``min(size_margin_mm / diameter_scale, mass_margin_kg / mass_scale)``.
    """

    name: str
    label: str
    interval_mm: tuple[float, float]
    size_margin_mm: float
    mass_margin_kg: float
    margin: float

    @property
    def correct(self) -> bool:
        """The margin is positive: the whole box gets one held outcome of its own."""
        return self.margin > 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (NaN as None)."""
        return {
            "name": self.name,
            "label": self.label,
            "interval_mm": [_num(v) for v in self.interval_mm],
            "size_margin_mm": _num(self.size_margin_mm),
            "mass_margin_kg": _num(self.mass_margin_kg),
            "margin": _num(self.margin),
        }


@dataclass(frozen=True)
class SortingMargins:
    """:func:`class_margins`'s result.

    Attributes
    ----------
    classes : tuple of ClassMargin
    margin : float
        The smallest class margin (dimensionless).
    boundaries_mm : ndarray
        Diameters where the loop's size class changes (mm), largest first.
    diameter_scale_mm, mass_scale_kg : float
    """

    classes: tuple[ClassMargin, ...]
    margin: float
    boundaries_mm: NDArray
    diameter_scale_mm: float
    mass_scale_kg: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record."""
        return {
            "margin": _num(self.margin),
            "classes": [c.to_dict() for c in self.classes],
            "boundaries_mm": [float(b) for b in self.boundaries_mm],
            "diameter_scale_mm": self.diameter_scale_mm,
            "mass_scale_kg": self.mass_scale_kg,
        }


def _num(value: float):
    return None if not math.isfinite(value) else float(value)


def _weights(pay: NDArray, tip: NDArray, size: NDArray, mass: float) -> NDArray:
    """Weight-class codes of a mass (kg) at diameters with these payloads (kg), as the loop."""
    from .._kernels.grasp import batch as kb

    out = np.full(pay.shape, kb.W_NOT_HELD)
    out[tip >= mass] = kb.W_HEAVY
    out[pay >= mass] = kb.W_LIGHT
    out[size < 0] = kb.W_NOT_HELD
    return out


class _Loop:
    """The loop at diameters (mm): size state and both payloads (kg), for an infinite weight."""

    def __init__(self, gripper: Gripper, setting: dict) -> None:
        self.gripper, self.setting = gripper, setting

    def __call__(self, diameters) -> tuple[NDArray, NDArray, NDArray]:
        from .._kernels.grasp import batch as kb

        d = np.asarray(diameters, dtype=float)
        table = run_sort(self.gripper, d, np.full(d.size, np.inf), **self.setting)
        size = table[:, kb.S_SIZE].astype(int)
        pay = np.nan_to_num(table[:, kb.S_PAYLOAD] / GRAVITY, nan=0.0)
        tip = np.nan_to_num(table[:, kb.S_PAYLOAD_TIP] / GRAVITY, nan=0.0)
        if not self.setting["tip_lasts"]:
            tip = np.zeros_like(tip)
        return size, pay, tip


def _keeps(loop_out, state: NDArray, weight: NDArray, m_lo: NDArray, m_hi: NDArray) -> NDArray:
    """Where the loop gives every mass of ``[m_lo, m_hi]`` the outcome ``(state, weight)``.

    Per row; ``weight = -1`` asks for the size state only (a size boundary).
    """
    size, pay, tip = loop_out
    same_weight = (_weights(pay, tip, size, m_lo) == weight) & (
        _weights(pay, tip, size, m_hi) == weight
    )
    return (size == state) & ((weight < 0) | same_weight)


def class_margins(
    gripper: Gripper,
    classes: list[ObjectClass] | tuple[ObjectClass, ...],
    *,
    mu: float = 0.5,
    tip_lasts: bool = True,
    depth: float | None = None,
    threshold: float | None = None,
    margin: float = 0.1,
    diameter_scale: float = 1.0,
    mass_scale: float = 1e-3,
    step: float = 1.0,
    tol: float = 0.01,
    options: GraspOptions | None = None,
) -> SortingMargins:
    """Each class's margin from the loop's boundaries (module docstring).

    Parameters
    ----------
    gripper : Gripper
    classes : sequence of ObjectClass
    mu : float
        Coulomb friction coefficient.
    tip_lasts : bool
        The tip unit lasts the lift (else ``heavy`` is never given).
    depth, threshold, margin, options
        As :func:`~.sort.sort_objects` (mm, N, fraction).
    diameter_scale : float, mm
    mass_scale : float, kg
        The margin counts ``diameter_scale`` of diameter as ``mass_scale`` of mass.
    step, tol : float, mm
        Grid step of the boundary search and the bisection's final bracket.
    """
    from .._kernels.grasp import batch as kb

    options = options or GraspOptions()
    loop = _Loop(
        gripper,
        {
            "mu": float(mu),
            "depth": gripper.default_depth() if depth is None else float(depth),
            "threshold": gripper.threshold(margin) if threshold is None else float(threshold),
            "tip_lasts": bool(tip_lasts),
            "options": options,
        },
    )
    top = gripper.open_aperture
    low = 0.5 * min(c.diameter[0] for c in classes)
    grid = np.linspace(low, top, max(math.ceil((top - low) / step) + 1, 2))
    n, k = grid.size, len(classes)
    # a class reaching past the open gripper is evaluated at its aperture (the grid's end)
    ends = np.minimum([d for c in classes for d in c.diameter], top)
    centres = np.minimum([c.centre[0] for c in classes], top)
    d_all = np.concatenate([grid, ends, centres])
    size, pay, tip = loop(d_all)
    grid_out = (size[:n], pay[:n], tip[:n])
    # each class's outcome at its centre
    c_rows = np.arange(n + ends.size, n + ends.size + k)
    state = size[c_rows]
    weight = np.array(
        [
            _weights(pay[r : r + 1], tip[r : r + 1], size[r : r + 1], c.centre[1])[0]
            for r, c in zip(c_rows, classes, strict=True)
        ]
    )
    m_lo = np.array([c.mass[0] for c in classes])
    m_hi = np.array([c.mass[1] for c in classes])
    centre_out = (size[c_rows], pay[c_rows], tip[c_rows])
    whole = _keeps(centre_out, state, weight, m_lo, m_hi)  # the centre's masses share it
    # brackets [inner, outer] to bisect, all at once: the size boundaries along the grid, then
    # each class's two sides (the first grid point out from its centre without its outcome)
    change = np.flatnonzero(size[1:n] != size[: n - 1])
    inner, outer = list(grid[change]), list(grid[change + 1])
    b_state, b_weight = list(size[change]), [-1] * change.size
    b_lo, b_hi = [0.0] * change.size, [0.0] * change.size
    sides: dict[tuple[int, int], object] = {}
    for i in range(k):
        if state[i] < 0 or not whole[i]:
            continue
        ok = _keeps(grid_out, state[i], np.full(n, weight[i]), m_lo[i], m_hi[i])
        for side in (-1, 1):
            idx = (
                np.flatnonzero(grid < centres[i])[::-1]
                if side < 0
                else np.flatnonzero(grid > centres[i])
            )
            bad = np.flatnonzero(~ok[idx])
            if not bad.size:  # the grid's end: half the smallest class, or the open gripper
                sides[i, side] = float(grid[idx[-1]]) if idx.size else float(centres[i])
                continue
            sides[i, side] = len(inner)
            inner.append(grid[idx[bad[0] - 1]] if bad[0] > 0 else centres[i])
            outer.append(grid[idx[bad[0]]])
            b_state.append(state[i])
            b_weight.append(weight[i])
            b_lo.append(m_lo[i])
            b_hi.append(m_hi[i])
    lo, hi = np.array(inner, dtype=float), np.array(outer, dtype=float)
    b_state, b_weight = np.array(b_state), np.array(b_weight)
    b_lo, b_hi = np.array(b_lo), np.array(b_hi)
    while lo.size and np.max(np.abs(hi - lo)) > tol:
        mid = 0.5 * (lo + hi)
        same = _keeps(loop(mid), b_state, b_weight, b_lo, b_hi)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    found = 0.5 * (lo + hi)
    boundaries = found[: change.size]
    records = []
    for i, c in enumerate(classes):
        (d_lo, d_hi), (mass_lo, mass_hi) = c.diameter, c.mass
        w = int(weight[i])
        label = f"{gripper.states[state[i]] if state[i] >= 0 else 'none'}/{WEIGHT_CLASSES[w]}"
        if (i, -1) in sides:
            ends_i = [sides[i, s] for s in (-1, 1)]
            interval = tuple(float(found[e]) if isinstance(e, int) else e for e in ends_i)
            diameter_margin = min(d_lo - interval[0], interval[1] - d_hi)
        else:
            interval = (math.nan, math.nan)
            diameter_margin = -0.5 * (d_hi - d_lo)
        inside = (d_all >= d_lo) & (d_all <= d_hi)
        p_box, t_box = pay[inside], tip[inside]
        if state[i] >= 0 and w == kb.W_LIGHT:
            mass_margin = float(np.min(p_box)) - mass_hi
        elif state[i] >= 0 and w == kb.W_HEAVY:
            mass_margin = min(mass_lo - float(np.max(p_box)), float(np.min(t_box)) - mass_hi)
        else:
            mass_margin = min(float(np.min(np.maximum(p_box, t_box))) - mass_hi, 0.0)
            # not held at its centre: also as far (in diameter) as the nearest diameter that
            # holds its heaviest mass, beyond half its width (the whole grid when none does)
            holds = (size[:n] >= 0) & (np.maximum(pay[:n], tip[:n]) >= mass_hi)
            reach = float(np.min(np.abs(grid[holds] - c.centre[0]))) if holds.any() else top - low
            diameter_margin = min(diameter_margin, -0.5 * (d_hi - d_lo) - reach)
        records.append((c, label, interval, diameter_margin, mass_margin))
    labels = [r[1] for r in records]
    out = []
    for c, label, interval, size_margin, mass_margin in records:
        if labels.count(label) > 1 or label.startswith("none/"):
            size_margin = min(size_margin, -0.5 * (c.diameter[1] - c.diameter[0]))
        value = min(size_margin / diameter_scale, mass_margin / mass_scale)
        out.append(
            ClassMargin(c.name, label, interval, float(size_margin), float(mass_margin), value)
        )
    return SortingMargins(
        classes=tuple(out),
        margin=min(c.margin for c in out),
        boundaries_mm=np.sort(boundaries)[::-1],
        diameter_scale_mm=float(diameter_scale),
        mass_scale_kg=float(mass_scale),
    )


def class_samples(
    classes: list[ObjectClass] | tuple[ObjectClass, ...],
    n_diameters: int = 5,
    n_masses: int = 3,
) -> Objects:
    """Objects sampled from each class: a grid over its box, edges included.

    ``n_diameters`` diameters evenly from ``d_lo`` to ``d_hi`` times ``n_masses`` masses from
    ``m_lo`` to ``m_hi`` (a single value once when the range is a point); each object's true
    class is its class's name.
    """
    names, diameters, masses, truth = [], [], [], []
    for c in classes:
        ds = np.unique(np.linspace(c.diameter[0], c.diameter[1], n_diameters))
        ms = np.unique(np.linspace(c.mass[0], c.mass[1], n_masses))
        for d in ds:
            for m in ms:
                names.append(f"{c.name}-{d:g}mm-{1e3 * m:g}g")
                diameters.append(float(d))
                masses.append(float(m))
                truth.append(c.name)
    return Objects(tuple(names), np.array(diameters), np.array(masses), tuple(truth))
