"""The gripper scene's sorting objective: the ``[gripper.sorting]`` table.

Its layout is in :mod:`dpfexplore.inverse.scenes.gripper.spec`.

Object classes (a name, a diameter range in mm, a mass or mass range in kg) that the paper's
loop (:mod:`dpfexplore.grasping.sort`) must tell apart; the design then maximises the smallest
class margin (:mod:`dpfexplore.grasping.classes`). Every problem is one
:class:`~dpfexplore.inverse.scene_file.SceneSpecError` naming the dotted key and the value.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ....grasping.classes import ObjectClass
from ....io.toml_fields import check_keys, integer_in, interval, positive_number, string
from ...scene_file import SceneSpecError

__all__ = ["SortingSpec", "check_open_gripper", "open_aperture", "parse_sorting"]

WHERE = "gripper.sorting"


@dataclass(frozen=True)
class SortingSpec:
    """The sorting objective of a gripper scene.

    Attributes
    ----------
    classes : tuple of ObjectClass
        Sorted by diameter, largest first.
    mu : float
        Coulomb friction coefficient at the contacts.
    lift_s : float
        The lift's duration (s): the tip unit is used only if it resets later.
    diameter_scale_mm, mass_scale_kg : float
        The margin counts this much diameter (mm) as this much mass (kg).
    max_evaluations : int
        Loop-margin evaluations of the aperture search.
    """

    classes: tuple[ObjectClass, ...]
    mu: float
    lift_s: float
    diameter_scale_mm: float
    mass_scale_kg: float
    max_evaluations: int


def _mass(value: Any, where: str) -> tuple[float, float]:
    """A mass (kg): a number >= 0 or ``{min, max}`` with ``0 <= min <= max``."""
    if isinstance(value, Mapping):
        low, high = interval(value, where, positive=False)
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneSpecError(f"{where} = {value!r}: give a mass in kg or {{min, max}}")
    else:
        low = high = float(value)
    if not (math.isfinite(low) and math.isfinite(high)):
        raise SceneSpecError(f"{where} = {value!r}: must be finite (kg)")
    if low < 0:
        raise SceneSpecError(f"{where} = {value!r}: a mass must be >= 0 kg")
    return low, high


def _classes(value: Any, n_states: int) -> tuple[ObjectClass, ...]:
    where = f"{WHERE}.classes"
    if not isinstance(value, list) or not value:
        raise SceneSpecError(f"{where} = {value!r}: need a list of one or more classes")
    if len(value) > 2 * n_states:
        raise SceneSpecError(
            f"{where}: {len(value)} classes, but the loop has {n_states} size states and two "
            f"held weight classes ({2 * n_states} outcomes)"
        )
    out = []
    for i, item in enumerate(value):
        at = f"{where}[{i}]"
        if not isinstance(item, Mapping):
            raise SceneSpecError(f"{at} = {item!r}: need a table {{name, diameter, mass}}")
        check_keys(item, at, required=("name", "diameter", "mass"), optional=())
        name = string(item, at, "name")
        if not name.strip():
            raise SceneSpecError(f"{at}.name = {name!r}: must not be empty")
        diameter = interval(item["diameter"], f"{at}.diameter")
        out.append(ObjectClass(name.strip(), diameter, _mass(item["mass"], f"{at}.mass")))
    names = [c.name for c in out]
    for name in names:
        if names.count(name) > 1:
            raise SceneSpecError(f"{where}: the name {name!r} is given twice")
    out.sort(key=lambda c: -c.diameter[0])
    for big, small in itertools.pairwise(out):
        if small.diameter[1] >= big.diameter[0]:
            raise SceneSpecError(
                f"{where}: the diameter ranges of {small.name!r} ({small.diameter[0]:g}-"
                f"{small.diameter[1]:g} mm) and {big.name!r} ({big.diameter[0]:g}-"
                f"{big.diameter[1]:g} mm) overlap: the loop sizes by diameter"
            )
    return tuple(out)


def parse_sorting(
    value: Any, states: Sequence[str], metastable_unit: int, min_reset_s: float
) -> SortingSpec:
    """The ``[gripper.sorting]`` table -> :class:`SortingSpec`."""
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{WHERE} = {value!r}: must be a table")
    check_keys(
        value,
        WHERE,
        required=("classes",),
        optional=("mu", "lift_s", "diameter_scale_mm", "mass_scale_kg", "max_evaluations"),
    )
    n = len(states[0])
    grasp = ["1" * k + "0" * (n - k) for k in range(1, n)]
    if list(states) != grasp:
        raise SceneSpecError(
            f"gripper.states = {list(states)}: the sorting loop closes through the grasp states "
            f"{grasp} (units 1..k inverted, the last unit the tip unit)"
        )
    if metastable_unit != n:
        raise SceneSpecError(
            f"gripper.metastable_unit = {metastable_unit}: the sorting loop's tip unit is the "
            f"last unit ({n})"
        )
    return SortingSpec(
        classes=_classes(value["classes"], len(states)),
        mu=positive_number(value, WHERE, "mu", 0.5, allow_zero=True),
        lift_s=positive_number(value, WHERE, "lift_s", min_reset_s, allow_zero=True),
        diameter_scale_mm=positive_number(value, WHERE, "diameter_scale_mm", 1.0),
        mass_scale_kg=positive_number(value, WHERE, "mass_scale_kg", 1e-3),
        max_evaluations=integer_in(value, WHERE, "max_evaluations", default=24, low=0, high=10_000),
    )


def open_aperture(design, base_L: float, theta_B_deg: float) -> float:
    """Aperture (mm) of ``design``'s open gripper (no unit inverted) on its base (mm, degrees)."""
    from ....model.gripper import gripper_aperture
    from ....solvers.lattice import lattice_params
    from ....solvers.statics import find_state

    tip = find_state(design, "0" * design.n_units).tip
    return float(gripper_aperture(tip, lattice_params(design).h, base_L, theta_B_deg))


def check_open_gripper(spec: SortingSpec, open_aperture: float, what: str) -> None:
    """Refuse a class wider than ``what``'s open gripper (mm)."""
    for c in spec.classes:
        if c.diameter[1] >= open_aperture:
            raise SceneSpecError(
                f"{WHERE}.classes: {c.name!r} reaches {c.diameter[1]:g} mm, not inside the open "
                f"gripper of {what} ({open_aperture:.2f} mm)"
            )
