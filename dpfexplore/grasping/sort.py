"""The size-and-weight sorting loop over many objects, and the sorting map.

The paper's loop (SI "Embodied Classification Task"), per object: close state by state in the
pressure sequence; the first state whose grasp decides (the sensor's reading above the
threshold, or the state lost to the object) is its size class; lift: held when that state's
payload is at least the object's weight (``light``); else invert the tip unit and lift again:
held then (and the tip unit lasts the lift) ``heavy``; else ``not_held``. Objects run in
parallel (:func:`dpfexplore._kernels.grasp.batch.sort_batch`).

Objects files are CSV with a header: ``name``, ``diameter`` (mm), ``mass`` (kg) and an optional
``class``, the true class: ``SIZE/WEIGHT`` (``11100/light``, ``none/not_held``) compared with
the loop's whole outcome, or ``SIZE`` alone compared with its size class.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model.design import Design
from .grasp import _disk, check_object, tip_reset_time
from .setup import GRAVITY, GraspOptions, Gripper, gripper_of

__all__ = [
    "WEIGHT_CLASSES",
    "Objects",
    "SortReport",
    "SortedObject",
    "read_objects",
    "sort_objects",
    "sorting_map",
]

#: Weight classes, in the order of the kernel's codes (``W_LIGHT``, ``W_HEAVY``, ``W_NOT_HELD``).
WEIGHT_CLASSES = ("light", "heavy", "not_held")


@dataclass(frozen=True)
class Objects:
    """Objects to sort.

    Attributes
    ----------
    names : tuple of str
    diameters : ndarray of shape (n,), mm
    masses : ndarray of shape (n,), kg
    classes : tuple of str or None
        The true classes, when given.
    """

    names: tuple[str, ...]
    diameters: NDArray
    masses: NDArray
    classes: tuple[str, ...] | None = None


def read_objects(path: str | Path) -> Objects:
    """Read an objects CSV (``name, diameter, mass[, class]``; mm, kg).

    Raises
    ------
    ValueError
        One line naming the file (and row, line and column): unreadable, a missing column, a
        value that is not a finite number or is negative, no rows.
    """
    from ..io.files import read_bounded

    path = Path(path)
    try:
        text = read_bounded(path, "objects").decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not UTF-8 text") from None
    except OSError as exc:
        raise ValueError(f"{path}: {exc.strerror or exc}") from None
    reader = csv.reader(io.StringIO(text))
    header = [h.strip().lower() for h in next(reader, [])]
    for column in ("name", "diameter", "mass"):
        if column not in header:
            raise ValueError(
                f"{path}: no column {column!r} (columns: {', '.join(header) or 'none'}; "
                "need name, diameter, mass[, class])"
            )
    where = {c: header.index(c) for c in ("name", "diameter", "mass")}
    has_class = "class" in header
    names, diameters, masses, classes = [], [], [], []
    for row_no, row in enumerate(reader, start=1):
        if not any(cell.strip() for cell in row):
            continue
        line = reader.line_num
        if len(row) < len(header):
            missing = header[len(row)]
            raise ValueError(f"{path}: row {row_no} (line {line}), column {missing!r}: missing")
        values = {}
        for column in ("diameter", "mass"):
            cell = row[where[column]].strip()
            try:
                value = float(cell)
            except ValueError:
                value = math.nan
            if not math.isfinite(value) or value < 0:
                what = "negative" if value < 0 else "not a finite number"
                raise ValueError(
                    f"{path}: row {row_no} (line {line}), column {column!r}: {cell!r} is {what}"
                )
            values[column] = value
        names.append(row[where["name"]].strip())
        diameters.append(values["diameter"])
        masses.append(values["mass"])
        if has_class:
            classes.append(row[header.index("class")].strip())
    if not names:
        raise ValueError(f"{path}: no objects (a header and one row per object)")
    return Objects(
        tuple(names),
        np.array(diameters),
        np.array(masses),
        tuple(classes) if has_class else None,
    )


@dataclass(frozen=True)
class SortedObject:
    """One object's outcome of the loop (units in the names).

    Attributes
    ----------
    name : str
    diameter_mm, mass_kg : float
    size_state : str or None
        The state that decided its size, None when none did.
    weight_class : str
        ``light``, ``heavy`` (held only with the tip unit) or ``not_held``.
    sensor_N, sensor_margin_N : float
        The reading at the deciding state (the last state tried when none decided) and its
        margin over the threshold (N).
    payload_kg, payload_tip_kg : float
        Payload of the deciding state without and with the tip unit inverted (NaN: none; the
        tip's only when the object slipped without it, as in the loop).
    payload_margin_kg : float
        The payload that held it (the tip's for ``heavy``; the larger for ``not_held``) minus
        its mass.
    true_class : str or None
    status : str
    """

    name: str
    diameter_mm: float
    mass_kg: float
    size_state: str | None
    weight_class: str
    sensor_N: float
    sensor_margin_N: float
    payload_kg: float
    payload_tip_kg: float
    payload_margin_kg: float
    true_class: str | None
    status: str

    @property
    def label(self) -> str:
        """The outcome as a class label, ``SIZE/WEIGHT`` (``none`` for no size)."""
        return f"{self.size_state or 'none'}/{self.weight_class}"

    def matches(self, true_class: str) -> bool:
        """Whether ``true_class`` (``SIZE/WEIGHT`` or ``SIZE``) is this outcome."""
        if "/" in true_class:
            return true_class == self.label
        return true_class == (self.size_state or "none")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (NaN as None)."""
        return {
            "name": self.name,
            "diameter": self.diameter_mm,
            "mass": self.mass_kg,
            "size_state": self.size_state,
            "weight_class": self.weight_class,
            "sensor_N": _num(self.sensor_N),
            "sensor_margin_N": _num(self.sensor_margin_N),
            "payload_kg": _num(self.payload_kg),
            "payload_tip_kg": _num(self.payload_tip_kg),
            "payload_margin_kg": _num(self.payload_margin_kg),
            "true_class": self.true_class,
            "status": self.status,
        }


def _num(value: float):
    return None if not math.isfinite(value) else float(value)


@dataclass(frozen=True)
class SortReport:
    """:func:`sort_objects`'s result.

    Attributes
    ----------
    objects : tuple of SortedObject
    mu, depth_mm, threshold_N : float
    tip_reset_s : float
        Reset time of the tip unit after its pulse (s).
    lift_s : float or None
        The lift's duration (s), as given.
    tip_lasts : bool
        Whether the tip unit stays inverted for the lift (``True`` when ``lift_s`` is None).
    confusion : dict or None
        ``{true class: {outcome: count}}`` when true classes were given.
    accuracy : float or None
    gripper : Gripper
    """

    objects: tuple[SortedObject, ...]
    mu: float
    depth_mm: float
    threshold_N: float
    tip_reset_s: float
    lift_s: float | None
    tip_lasts: bool
    confusion: dict | None
    accuracy: float | None
    gripper: Gripper = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready document."""
        return {
            "mu": self.mu,
            "depth_mm": self.depth_mm,
            "threshold_N": self.threshold_N,
            "tip_reset_s": _num(self.tip_reset_s),
            "lift_s": self.lift_s,
            "tip_lasts": self.tip_lasts,
            "objects": [o.to_dict() for o in self.objects],
            "confusion": self.confusion,
            "accuracy": self.accuracy,
        }


def sort_setup(gripper: Gripper, threshold: float, tip_lasts: bool):
    """The sorting kernel's :class:`~dpfexplore._kernels.grasp.records.SortSetup`."""
    from .._kernels.grasp.records import SortSetup
    from .setup import state_bits

    return SortSetup(
        gripper.unit_params,
        gripper.held_params,
        gripper.h,
        np.ascontiguousarray(np.array([state_bits(s) for s in gripper.states])),
        np.ascontiguousarray(np.array([state_bits(s) for s in gripper.held_states])),
        gripper.x_free,
        gripper.x_held,
        float(threshold),
        bool(tip_lasts),
    )


def run_sort(gripper, diameters, weights_N, *, mu, depth, threshold, tip_lasts, options):
    """The kernel's table ``(n, N_SORT)`` for objects of ``diameters`` (mm) and weights (N)."""
    from .._kernels.grasp.batch import N_SORT, sort_batch

    disk = _disk(gripper, 1.0, depth, mu)
    frame = np.array([disk.cx, disk.cy, disk.ax, disk.ay, disk.offset, disk.mu])
    objects = np.ascontiguousarray(np.column_stack([diameters, weights_N]), dtype=float)
    result = np.empty((objects.shape[0], N_SORT))
    setup = sort_setup(gripper, threshold, tip_lasts)
    sort_batch(objects, setup, frame, options.controls(gripper.unit_params), result)
    return result


def sort_objects(
    design: Design | Gripper,
    objects: Objects | str | Path,
    *,
    mu: float = 0.5,
    lift_s: float | None = None,
    depth: float | None = None,
    threshold: float | None = None,
    margin: float = 0.1,
    options: GraspOptions | None = None,
) -> SortReport:
    """Run the sorting loop on each object (in parallel); with true classes, the confusion.

    Parameters
    ----------
    design : Design or Gripper
    objects : Objects or path
        The objects, or an objects CSV (:func:`read_objects`).
    mu : float
        Coulomb friction coefficient at the contacts.
    lift_s : float, optional, s
        The lift's duration: the tip unit is used only if its reset time is at least this.
    depth, threshold, margin, options
        As :func:`~dpfexplore.grasping.grasp.grasp`.
    """
    from .._kernels.grasp import batch as kb
    from ..model.status import Status

    gripper = design if isinstance(design, Gripper) else gripper_of(design)
    if not isinstance(objects, Objects):
        objects = read_objects(objects)
    for name, d, m in zip(objects.names, objects.diameters, objects.masses, strict=True):
        try:
            check_object(float(d), float(m), mu, gripper.open_aperture)
        except ValueError as exc:
            raise ValueError(f"object {name!r}: {exc}") from None
    if lift_s is not None and not (math.isfinite(lift_s) and lift_s >= 0):
        raise ValueError(f"lift_s = {lift_s!r} s: must be a finite number >= 0")
    if threshold is not None and not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold = {threshold!r} N: must be a finite number > 0")
    options = options or GraspOptions()
    depth = gripper.default_depth() if depth is None else float(depth)
    thr = gripper.threshold(margin) if threshold is None else float(threshold)
    reset = tip_reset_time(gripper.design)
    lasts = lift_s is None or bool(reset >= lift_s)
    weights = objects.masses * GRAVITY
    table = run_sort(
        gripper,
        objects.diameters,
        weights,
        mu=mu,
        depth=depth,
        threshold=thr,
        tip_lasts=lasts,
        options=options,
    )
    records = []
    for i, name in enumerate(objects.names):
        row = table[i]
        j = int(row[kb.S_SIZE])
        weight_class = WEIGHT_CLASSES[int(row[kb.S_WEIGHT])]
        pay, tip = row[kb.S_PAYLOAD] / GRAVITY, row[kb.S_PAYLOAD_TIP] / GRAVITY
        held_by = (
            tip
            if weight_class == "heavy"
            else (pay if weight_class == "light" else np.fmax(pay, tip))
        )
        records.append(
            SortedObject(
                name=name,
                diameter_mm=float(objects.diameters[i]),
                mass_kg=float(objects.masses[i]),
                size_state=gripper.states[j] if j >= 0 else None,
                weight_class=weight_class,
                sensor_N=float(row[kb.S_READING]),
                sensor_margin_N=float(row[kb.S_READING]) - thr,
                payload_kg=float(pay),
                payload_tip_kg=float(tip),
                payload_margin_kg=float(held_by - objects.masses[i]),
                true_class=objects.classes[i] if objects.classes is not None else None,
                status=Status(int(row[kb.S_STATUS])).label,
            )
        )
    confusion = accuracy = None
    if objects.classes is not None:
        confusion = {}
        for r in records:
            cell = confusion.setdefault(r.true_class, {})
            cell[r.label] = cell.get(r.label, 0) + 1
        accuracy = sum(r.matches(r.true_class) for r in records) / len(records)
    return SortReport(
        objects=tuple(records),
        mu=float(mu),
        depth_mm=depth,
        threshold_N=thr,
        tip_reset_s=reset,
        lift_s=lift_s,
        tip_lasts=lasts,
        confusion=confusion,
        accuracy=accuracy,
        gripper=gripper,
    )


def sorting_map(
    gripper: Gripper,
    diameters: NDArray,
    masses: NDArray,
    *,
    mu: float = 0.5,
    depth: float | None = None,
    threshold: float | None = None,
    margin: float = 0.1,
    tip_lasts: bool = True,
    options: GraspOptions | None = None,
) -> tuple[NDArray, NDArray]:
    """The loop's outcome over a grid of diameters (mm) × masses (kg).

    A state's grasp and payloads do not depend on the object's mass, so the loop runs once per
    diameter (in parallel) and each mass is classed by its payloads: the same outcome as the
    loop on every grid point, bit for bit.

    Returns
    -------
    size : ndarray of int, shape (n_masses, n_diameters)
        Index of the deciding state (-1: none).
    weight : ndarray of int, shape (n_masses, n_diameters)
        Weight class code (index into :data:`WEIGHT_CLASSES`).
    """
    from .._kernels.grasp import batch as kb

    options = options or GraspOptions()
    depth = gripper.default_depth() if depth is None else float(depth)
    thr = gripper.threshold(margin) if threshold is None else float(threshold)
    d = np.asarray(diameters, dtype=float)
    w = np.asarray(masses, dtype=float) * GRAVITY
    table = run_sort(  # an infinite weight slips: both payloads of each diameter
        gripper,
        d,
        np.full_like(d, np.inf),
        mu=mu,
        depth=depth,
        threshold=thr,
        tip_lasts=tip_lasts,
        options=options,
    )
    size = np.broadcast_to(table[:, kb.S_SIZE].astype(int), (w.size, d.size)).copy()
    pay = table[:, kb.S_PAYLOAD][None, :]
    tip = table[:, kb.S_PAYLOAD_TIP][None, :]
    weight = np.full((w.size, d.size), kb.W_NOT_HELD)
    weight[(tip >= w[:, None]) & tip_lasts] = kb.W_HEAVY
    weight[pay >= w[:, None]] = kb.W_LIGHT
    weight[size < 0] = kb.W_NOT_HELD
    return size, weight


def report_map(
    report: SortReport, smallest_mm: float, heaviest_kg: float, points: tuple[int, int] = (100, 100)
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """:func:`sorting_map` of a sort report's gripper, under the report's conditions.

    The grid spans half ``smallest_mm`` to the open gripper's aperture (mm) and 0 to 1.5 times
    ``heaviest_kg`` (at least 1.5 g), ``points`` = (diameters, masses); friction, depth,
    threshold and tip unit are those ``report``'s objects were sorted under.

    Returns
    -------
    diameters, masses, size, weight
        The grid (mm, kg) and :func:`sorting_map`'s ``(size, weight)`` over it.
    """
    diameters = np.linspace(0.5 * smallest_mm, report.gripper.open_aperture, points[0])
    masses = np.linspace(0.0, 1.5 * max(heaviest_kg, 1e-3), points[1])
    size, weight = sorting_map(
        report.gripper,
        diameters,
        masses,
        mu=report.mu,
        depth=report.depth_mm,
        threshold=report.threshold_N,
        tip_lasts=report.tip_lasts,
    )
    return diameters, masses, size, weight
