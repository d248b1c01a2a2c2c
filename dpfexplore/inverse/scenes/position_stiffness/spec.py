"""Scene file of the position-and-stiffness scene (paper eq. opti_pos_stiff).

The position scene's targets and ``[objective]`` (:mod:`dpfexplore.inverse.scenes.position.spec`,
read by its :func:`~dpfexplore.inverse.scenes.position.spec.read_position`) and two keys more::

    [scene]
    kind = "position_stiffness"

    [objective]
    front = [0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0]   # tip tolerances of the front, mm
    weights = [1.0, 1.0]          # optional: also solve the paper's w1 |r|² + w2 (1/K)²
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ....io.toml_fields import numbers
from ...scene_file import SceneSpecError
from ...spec import SceneCommon
from ..position.spec import PositionSpec, read_position

__all__ = ["DEFAULT_FRONT", "PositionStiffnessSpec", "parse_position_stiffness"]

#: Tip tolerances of the front when the scene gives none, mm.
DEFAULT_FRONT = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)


@dataclass(frozen=True)
class PositionStiffnessSpec(PositionSpec):
    """A position scene that also asks for the stiffest designs.

    Attributes
    ----------
    front : tuple of float
        Tip tolerances of the stiffness front, mm, ascending.
    weights : (w1, w2) or None
        The paper's weighted sum ``w1 |r|² + w2 (1/K)²``, if asked.
    """

    front: tuple[float, ...] = DEFAULT_FRONT
    weights: tuple[float, float] | None = None


def parse_position_stiffness(data: Mapping[str, Any], common: SceneCommon) -> PositionStiffnessSpec:
    """The kind's own tables (module docstring) -> :class:`PositionStiffnessSpec`."""
    targets, state, tolerance, objective = read_position(
        data, common, objective_keys=("front", "weights")
    )
    front = objective.get("front", list(DEFAULT_FRONT))
    front = numbers(front, "objective.front", length=None, unit="mm")
    if not front or any(v <= 0 for v in front):
        raise SceneSpecError(f"objective.front = {front!r}: need tolerances > 0 mm")
    weights = None
    if "weights" in objective:
        w = numbers(objective["weights"], "objective.weights", length=2, unit="")
        if any(v < 0 for v in w) or not any(v > 0 for v in w):
            raise SceneSpecError(f"objective.weights = {list(w)!r}: need w >= 0, not both 0")
        weights = (w[0], w[1])
    return PositionStiffnessSpec(
        targets=targets,
        state=state,
        tolerance=tolerance,
        front=tuple(sorted(front)),
        weights=weights,
    )
