"""Checks of scene-file values that both timing scenes use (pick-and-place and walker leg)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..spec_fields import SceneSpecError

__all__ = ["boolean", "integer"]


def integer(
    table: Mapping[str, Any], where: str, key: str, default: int, low: int, high: int
) -> int:
    """``table[key]`` (or ``default``): an integer in ``[low, high]``, else a named error."""
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise SceneSpecError(f"{where}.{key} = {value!r}: an integer in [{low}, {high}]")
    return value


def boolean(table: Mapping[str, Any], where: str, key: str, default: bool) -> bool:
    """``table[key]`` (or ``default``): true or false, else a named error."""
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise SceneSpecError(f"{where}.{key} = {value!r}: must be true or false")
    return value
