"""Field parsers shared by the scene formats: one-line errors naming the key.

:mod:`.scene_file` (position and gripper scenes) and :mod:`.scenes.timing_spec` (pick-and-place and
walker scenes) read their tables with these; keeping them apart from both lets the scene-kind
table (:mod:`.kinds`) import every format without an import cycle. The names keep their leading
underscore: they are the scene readers' shared internals, not a public API.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..sweep.job_fields import JobSpecError, check_keys

__all__ = ["SceneSpecError"]


class SceneSpecError(JobSpecError):
    """A scene file that does not validate; the message is one line naming the key."""


def _bound(value: Any, where: str) -> float | tuple[float, float]:
    """A number (fixed) or ``{min, max}`` -> DesignVariables' number or ``(low, high)``."""
    if isinstance(value, Mapping):
        return _range(value, where)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneSpecError(f"{where} = {value!r}: give a number or {{min, max}}")
    if not (math.isfinite(value) and value > 0):
        raise SceneSpecError(f"{where} = {value!r}: must be finite and > 0")
    return float(value)


def _range(value: Any, where: str, *, positive: bool = True) -> tuple[float, float]:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: give {{min, max}}")
    _keys(value, where, required=("min", "max"), optional=())
    low, high = value["min"], value["max"]
    for key, v in (("min", low), ("max", high)):
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not math.isfinite(v)
            or (positive and v <= 0)
        ):
            raise SceneSpecError(
                f"{where}.{key} = {v!r}: must be a finite number" + (" > 0" if positive else "")
            )
    if low > high:
        raise SceneSpecError(f"{where}.min = {low}: greater than max = {high}")
    return float(low), float(high)


def _numbers(value: Any, where: str, *, length: int | None, unit: str) -> tuple[float, ...]:
    if not isinstance(value, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
    ):
        raise SceneSpecError(
            f"{where} = {value!r}: need a list of finite numbers" + (f" ({unit})" if unit else "")
        )
    if length is not None and len(value) != length:
        raise SceneSpecError(f"{where} = {value!r}: need {length} numbers, got {len(value)}")
    return tuple(float(v) for v in value)


def _positive(
    table: Mapping[str, Any], where: str, key: str, default: float, *, allow_zero: bool = False
) -> float:
    value = table.get(key, default)
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value < 0
        or (value == 0 and not allow_zero)
    ):
        raise SceneSpecError(f"{where}.{key} = {value!r}: must be a finite number > 0")
    return float(value)


def _string(table: Mapping[str, Any], where: str, key: str, default: str) -> str:
    value = table.get(key, default)
    if not isinstance(value, str):
        raise SceneSpecError(f"{where}.{key} = {value!r}: must be a string")
    return value


def _table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data[key]
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{key} = {value!r}: must be a table")
    return value


def _keys(
    table: Mapping[str, Any], where: str, *, required: Sequence[str], optional: Sequence[str]
) -> None:
    try:
        check_keys(table, where, required=tuple(required), optional=tuple(optional))
    except JobSpecError as exc:
        raise SceneSpecError(str(exc)) from None


def _plain(value: Any) -> Any:
    """A JSON-ready copy of a TOML document."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
