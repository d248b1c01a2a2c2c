"""Validators of the TOML-shaped mappings of job files (and of scene files, which reuse them).

Each failure is a :class:`JobSpecError` whose one-line message starts with the dotted key. These
say what a well-formed value looks like; :mod:`dpfexplore.sweep.job_file` says which values a
job takes, :mod:`dpfexplore.sweep.space` what a job is.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any


class JobSpecError(ValueError):
    """A job file that does not validate; the message is one line naming the key."""


def check_keys(
    table: Mapping[str, Any], where: str, *, required: tuple[str, ...], optional: tuple[str, ...]
) -> None:
    """Refuse a key of ``table`` that is neither required nor optional, and a missing one."""
    known = (*required, *optional)
    for key in table:
        if key not in known:
            full = f"{where}.{key}" if where else key
            value = table[key]
            shown = "{...}" if isinstance(value, Mapping) else repr(value)
            raise JobSpecError(f"{full} = {shown}: unknown key; known: {', '.join(known)}")
    for key in required:
        if key not in table:
            full = f"{where}.{key}" if where else key
            raise JobSpecError(f"{full}: missing key")


def table(data: Mapping[str, Any], *path: str) -> Mapping[str, Any]:
    """The sub-table at the dotted ``path`` (its last key under ``data``)."""
    value = data[path[-1]]
    if not isinstance(value, Mapping):
        key = ".".join(path)
        raise JobSpecError(f"{key} = {value!r}: must be a table")
    return value


def integer(table: Mapping[str, Any], where: str, key: str, *, low: int, high: int) -> int:
    """An integer in ``[low, high]`` (a bool is not an integer here)."""
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise JobSpecError(f"{where}.{key} = {value!r}: must be an integer")
    if not low <= value <= high:
        raise JobSpecError(f"{where}.{key} = {value}: must be between {low} and {high}")
    return value


def positive(table: Mapping[str, Any], where: str, key: str, unit: str) -> float:
    """A finite number > 0 in ``unit`` (named in the message)."""
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise JobSpecError(f"{where}.{key} = {value!r}: must be a number ({unit})")
    if not (math.isfinite(value) and value > 0):
        raise JobSpecError(f"{where}.{key} = {value!r}: must be finite and > 0 {unit}")
    return float(value)


def boolean(table: Mapping[str, Any], where: str, key: str, *, default: bool) -> bool:
    """``true`` or ``false``; ``default`` when the key is absent."""
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise JobSpecError(f"{where}.{key} = {value!r}: must be true or false")
    return value


def string(table: Mapping[str, Any], where: str, key: str, *, default: str | None = None) -> str:
    """A string; ``default`` when the key is absent."""
    value = table.get(key, default)
    if not isinstance(value, str):
        raise JobSpecError(f"{where}.{key} = {value!r}: must be a string")
    return value


def choice(
    table: Mapping[str, Any],
    where: str,
    key: str,
    choices: tuple[str, ...],
    *,
    default: str | None = None,
) -> str:
    """One of ``choices``; ``default`` when the key is absent (and a default is given)."""
    if key not in table and default is not None:
        return default
    value = table[key]
    if value not in choices:
        raise JobSpecError(f"{where}.{key} = {value!r}: must be one of {', '.join(choices)}")
    return value
