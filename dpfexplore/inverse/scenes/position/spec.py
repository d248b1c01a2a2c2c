"""Scene file of the position scene: its targets and ``[objective]`` (paper eq. opti_pos).

The tables every kind shares (``[scene]``, ``[variables]``, ``[optimiser]``) are read by
:mod:`dpfexplore.inverse.scene_file`; this module reads the kind's own. As there, every problem
is one :class:`~dpfexplore.inverse.scene_file.SceneSpecError` whose one-line message starts with
the dotted key. Lengths in mm (model frame of MODEL.md §5)::

    [scene]
    kind = "position"

    [[targets]]                   # one table per target
    point = [46.0, 32.0]          # tip (x, y) of the targeted state, mm
    reference = {H = [...], U_L = 9.98, U_sep = 2.26, t = 0.9, t_lim = 1.89}  # optional:
                                  # a design to compare with (e.g. the paper's), material's E

    [objective]
    state = "all_inverted"        # the targeted state ("all_inverted" or bits when N is fixed)
    tolerance = 1e-6              # mm²: a target is met when |tip - target|² <= tolerance

``dpfexplore design --seeds DATASET`` (:func:`with_seeds`) starts the scene's candidates from a
sweep dataset's nearest tips.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from ....io.toml_fields import check_keys, numbers, positive_number, string
from ....model.design import Design
from ...scene_file import SceneSpecError, check_seeds, reference_design
from ...spec import SceneCommon, SceneSpec

__all__ = [
    "MAX_TARGET_DISTANCE",
    "PositionSpec",
    "Target",
    "parse_position",
    "read_position",
    "with_seeds",
]

#: Farthest tip target accepted (mm along either axis): far beyond any finger of MAX_UNITS
#: units, near enough that squared distances stay finite.
MAX_TARGET_DISTANCE = 1000.0


@dataclass(frozen=True)
class Target:
    """One target of a position scene.

    Attributes
    ----------
    point : tuple of float
        Tip ``(x, y)`` of the targeted state, mm (model frame).
    reference : Design or None
        A design to compare with (e.g. the paper's), with the scene's material.
    """

    point: tuple[float, float]
    reference: Design | None = None


@dataclass(frozen=True)
class PositionSpec:
    """The position scene's targets and objective.

    Attributes
    ----------
    targets : tuple of Target
    state : str
        ``"all_inverted"`` or a bit string: the targeted state.
    tolerance : float
        mm²: a target is met when ``|tip - target|² <= tolerance``.
    """

    targets: tuple[Target, ...]
    state: str = "all_inverted"
    tolerance: float = 1e-6

    @property
    def n_results(self) -> int:
        """One result row per target."""
        return len(self.targets)


def read_position(
    data: Mapping[str, Any], common: SceneCommon, *, objective_keys: tuple[str, ...] = ()
) -> tuple[tuple[Target, ...], str, float, Mapping[str, Any]]:
    """The targets, state and tolerance of a position-shaped scene, and its ``[objective]``.

    ``objective_keys``: further keys the kind's ``[objective]`` may have (read by its parser).
    """
    if "gripper" in data:
        raise SceneSpecError(f"gripper = {{...}}: unknown table for kind {common.kind!r}")
    if "targets" not in data:
        raise SceneSpecError("targets: missing; give [[targets]] tables with point = [x, y]")
    raw = data["targets"]
    if not isinstance(raw, list) or not raw or not all(isinstance(t, Mapping) for t in raw):
        raise SceneSpecError("targets: need one or more [[targets]] tables")
    targets = []
    for i, entry in enumerate(raw):
        where = f"targets[{i}]"
        check_keys(entry, where, required=("point",), optional=("reference",))
        point = numbers(entry["point"], f"{where}.point", length=2, unit="mm")
        if max(abs(point[0]), abs(point[1])) > MAX_TARGET_DISTANCE:
            raise SceneSpecError(
                f"{where}.point = {list(point)}: more than {MAX_TARGET_DISTANCE:g} mm from the "
                "base; no finger of this model reaches that far"
            )
        reference = None
        if "reference" in entry:
            reference = reference_design(entry["reference"], f"{where}.reference", common)[0]
        targets.append(Target(point=(point[0], point[1]), reference=reference))
    objective = data.get("objective", {})
    if not isinstance(objective, Mapping):
        raise SceneSpecError(f"objective = {objective!r}: must be a table")
    check_keys(
        objective, "objective", required=(), optional=("state", "tolerance", *objective_keys)
    )
    state = string(objective, "objective", "state", default="all_inverted")
    if state != "all_inverted":
        if len(common.n_units) != 1 or len(state) != common.n_units[0] or set(state) - {"0", "1"}:
            raise SceneSpecError(
                f"objective.state = {state!r}: 'all_inverted', or a bit string of N characters "
                "when variables.n_units is one number"
            )
    tolerance = positive_number(objective, "objective", "tolerance", 1e-6)
    return tuple(targets), state, tolerance, objective


def parse_position(data: Mapping[str, Any], common: SceneCommon) -> PositionSpec:
    """The kind's own tables (module docstring) -> :class:`PositionSpec`."""
    targets, state, tolerance, _ = read_position(data, common)
    return PositionSpec(targets=targets, state=state, tolerance=tolerance)


def with_seeds(spec: SceneSpec, dataset: str) -> SceneSpec:
    """The scene with its candidates seeded from ``dataset`` (``dpfexplore design --seeds``)."""
    if not isinstance(spec.kind_spec, PositionSpec):
        raise SceneSpecError(f"--seeds: only position scenes take seeds, not {spec.kind!r}")
    settings = replace(spec.optimiser, seeds=check_seeds(dataset, "--seeds"))
    return replace(spec, optimiser=settings)
