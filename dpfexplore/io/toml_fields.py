"""Fields of TOML-shaped mappings: the one reader of job, scene, leg and unit-cell job files.

Each reader takes a table (a mapping from a parsed TOML document), the dotted path of that
table (``where``, e.g. ``"space.variables"``; ``""`` for the top level) and a key, checks the
value and returns it, or raises :class:`FieldError` (a ``ValueError``) whose one-line message
starts with the dotted key and says what a well-formed value looks like, e.g.
``space.variables.H.min = 6.0: greater than max = 5.0``. A file format's entry point reports
them as its own error class (:func:`reported_as`): ``JobSpecError`` for jobs
(:mod:`dpfexplore.sweep.job_file`), ``SceneSpecError`` for scenes
(:mod:`dpfexplore.inverse.scene_file`); legs (:mod:`dpfexplore.solvers.legs.leg`), unit-cell jobs
(:mod:`dpfexplore.unitcell.sweep`) and design files (:func:`dpfexplore.model.design.load_design`)
raise them as they are.

Where two formats word the same check differently, each wording has its reader, so that every
message a user sees keeps its text:

=========================  ========================================================
jobs                       :func:`integer`, :func:`positive`, :func:`choice`
scenes                     :func:`integer_in`, :func:`positive_number`, :func:`bound`,
                           :func:`interval`, :func:`numbers`, :func:`plain`
legs                       :func:`known_keys`
unit-cell jobs             :func:`check_keys`, :func:`table`, :func:`integer`,
                           :func:`positive`, :func:`numbers` (``one=True``)
jobs and scenes            :func:`check_keys`, :func:`table`, :func:`string`,
                           :func:`boolean`
every file                 :func:`read_toml`
=========================  ========================================================
"""

from __future__ import annotations

import contextlib
import math
import tomllib
from collections.abc import Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from .files import BoundedReadError, read_bounded

__all__ = [
    "FieldError",
    "boolean",
    "bound",
    "check_keys",
    "choice",
    "integer",
    "integer_in",
    "interval",
    "known_keys",
    "numbers",
    "plain",
    "positive",
    "positive_number",
    "read_toml",
    "reported_as",
    "string",
    "table",
]


class FieldError(ValueError):
    """A field of a TOML file that does not validate; the message is one line naming the key."""


@contextlib.contextmanager
def reported_as(error: type[FieldError]) -> Iterator[None]:
    """Re-raise a :class:`FieldError` of the block as ``error`` (a subclass), same message.

    An error of the block that already is an ``error`` passes unchanged.
    """
    try:
        yield
    except FieldError as exc:
        if isinstance(exc, error):
            raise
        raise error(str(exc)) from None


def read_toml(path: str | Path, kind: str = "toml") -> dict[str, Any]:
    """The document of the TOML file ``path``, read within the size limit of its ``kind``.

    ``kind`` is a key of :data:`dpfexplore.io.files.SIZE_LIMITS` (``"design"``, ``"job"``,
    ``"scene"``, ``"leg"``, ...): a directory, a FIFO, a device or a file larger than the limit
    is refused before it is read (:func:`~dpfexplore.io.files.read_bounded`).

    Raises
    ------
    FieldError
        ``PATH: not valid TOML (...)``, ``PATH: is a directory, not a ...``, ``PATH: not a
        regular file (...)``, ``PATH: N bytes, more than the limit of ...``.
    OSError, UnicodeDecodeError
        As :func:`open` and the decoder raise them: each format names what it could not read.
    """
    path = Path(path)
    try:
        raw = read_bounded(path, kind)
    except BoundedReadError as exc:
        raise FieldError(str(exc)) from None
    text = raw.decode("utf-8")
    try:
        return tomllib.loads(text)
    except ValueError as exc:  # TOMLDecodeError, or an integer of more digits than int() reads
        raise FieldError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:
        raise FieldError(f"{path}: not valid TOML (nested too deeply)") from None


# ----------------------------------------------------------------------------- keys and tables


def _dotted(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def check_keys(
    table: Mapping[str, Any],
    where: str,
    *,
    required: Sequence[str] = (),
    optional: Sequence[str] = (),
) -> None:
    """Refuse a key of ``table`` that is neither required nor optional, and a missing one.

    ``WHERE.KEY = VALUE: unknown key; known: ...`` (in the order given) and
    ``WHERE.KEY: missing key``.
    """
    known = (*required, *optional)
    for key in table:
        if key not in known:
            value = table[key]
            shown = "{...}" if isinstance(value, Mapping) else repr(value)
            raise FieldError(
                f"{_dotted(where, key)} = {shown}: unknown key; known: {', '.join(known)}"
            )
    for key in required:
        if key not in table:
            raise FieldError(f"{_dotted(where, key)}: missing key")


def known_keys(table: Any, where: str, known: Collection[str]) -> None:
    """Refuse a ``table`` that is not a table and a key it has that is not in ``known``.

    ``WHERE: must be a table`` and ``WHERE.KEY: unknown key; known: ...`` (sorted).
    """
    if not isinstance(table, Mapping):
        raise FieldError(f"{where}: must be a table")
    for key in table:
        if key not in known:
            raise FieldError(f"{where}.{key}: unknown key; known: {', '.join(sorted(known))}")


def table(data: Mapping[str, Any], *path: str) -> Mapping[str, Any]:
    """The sub-table at the dotted ``path`` (its last key under ``data``)."""
    value = data[path[-1]]
    if not isinstance(value, Mapping):
        raise FieldError(f"{'.'.join(path)} = {value!r}: must be a table")
    return value


def plain(value: Any) -> Any:
    """A JSON-ready copy of a TOML document (tables as dicts, arrays as lists)."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


# ----------------------------------------------------------------------------- scalars


def _number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float))


def integer(table: Mapping[str, Any], where: str, key: str, *, low: int, high: int) -> int:
    """``table[key]``: an integer in ``[low, high]`` (a bool is not an integer here).

    ``...: must be an integer`` and ``...: must be between LOW and HIGH``.
    """
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise FieldError(f"{where}.{key} = {value!r}: must be an integer")
    if not low <= value <= high:
        raise FieldError(f"{where}.{key} = {value}: must be between {low} and {high}")
    return value


def integer_in(
    table: Mapping[str, Any], where: str, key: str, *, default: int, low: int, high: int
) -> int:
    """``table[key]`` (or ``default``): an integer in ``[low, high]``.

    ``...: an integer in [LOW, HIGH]``.
    """
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise FieldError(f"{where}.{key} = {value!r}: an integer in [{low}, {high}]")
    return value


def positive(table: Mapping[str, Any], where: str, key: str, unit: str) -> float:
    """``table[key]``: a finite number > 0 in ``unit`` (named in the message)."""
    value = table[key]
    if not _number(value):
        raise FieldError(f"{where}.{key} = {value!r}: must be a number ({unit})")
    if not (math.isfinite(value) and value > 0):
        raise FieldError(f"{where}.{key} = {value!r}: must be finite and > 0 {unit}")
    return float(value)


def positive_number(
    table: Mapping[str, Any], where: str, key: str, default: float, *, allow_zero: bool = False
) -> float:
    """``table[key]`` (or ``default``): a finite number > 0 (>= 0 with ``allow_zero``).

    ``...: must be a finite number > 0``.
    """
    value = table.get(key, default)
    if (
        not _number(value)
        or not math.isfinite(value)
        or value < 0
        or (value == 0 and not allow_zero)
    ):
        raise FieldError(f"{where}.{key} = {value!r}: must be a finite number > 0")
    return float(value)


def boolean(table: Mapping[str, Any], where: str, key: str, *, default: bool) -> bool:
    """``table[key]`` (or ``default``): ``true`` or ``false``."""
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise FieldError(f"{where}.{key} = {value!r}: must be true or false")
    return value


def string(table: Mapping[str, Any], where: str, key: str, *, default: str | None = None) -> str:
    """``table[key]`` (or ``default``): a string."""
    value = table.get(key, default)
    if not isinstance(value, str):
        raise FieldError(f"{where}.{key} = {value!r}: must be a string")
    return value


def choice(
    table: Mapping[str, Any],
    where: str,
    key: str,
    choices: Sequence[str],
    *,
    default: str | None = None,
) -> str:
    """``table[key]``: one of ``choices``; ``default`` when the key is absent (if given)."""
    if key not in table and default is not None:
        return default
    value = table[key]
    if value not in choices:
        raise FieldError(f"{where}.{key} = {value!r}: must be one of {', '.join(choices)}")
    return value


# ----------------------------------------------------------------------------- compound values


def interval(value: Any, where: str, *, positive: bool = True) -> tuple[float, float]:
    """``{min, max}``: finite numbers (> 0 when ``positive``) with ``min <= max``."""
    if not isinstance(value, Mapping):
        raise FieldError(f"{where} = {value!r}: give {{min, max}}")
    check_keys(value, where, required=("min", "max"), optional=())
    low, high = value["min"], value["max"]
    for key, v in (("min", low), ("max", high)):
        if not _number(v) or not math.isfinite(v) or (positive and v <= 0):
            raise FieldError(
                f"{where}.{key} = {v!r}: must be a finite number" + (" > 0" if positive else "")
            )
    if low > high:
        raise FieldError(f"{where}.min = {low}: greater than max = {high}")
    return float(low), float(high)


def bound(value: Any, where: str) -> float | tuple[float, float]:
    """A number > 0 (fixed) or ``{min, max}`` (:func:`interval`): a number or ``(low, high)``."""
    if isinstance(value, Mapping):
        return interval(value, where)
    if not _number(value):
        raise FieldError(f"{where} = {value!r}: give a number or {{min, max}}")
    if not (math.isfinite(value) and value > 0):
        raise FieldError(f"{where} = {value!r}: must be finite and > 0")
    return float(value)


def numbers(
    value: Any, where: str, *, length: int | None, unit: str, one: bool = False
) -> tuple[float, ...]:
    """A list of finite numbers (of ``length`` entries, when given) in ``unit``.

    With ``one``, a single number stands for the list of it (``3.0`` reads as ``(3.0,)``).
    """
    items = [value] if one and not isinstance(value, list) else value
    if not isinstance(items, list) or not all(_number(v) and math.isfinite(v) for v in items):
        need = "a number or a list of finite numbers" if one else "a list of finite numbers"
        raise FieldError(f"{where} = {value!r}: need {need}" + (f" ({unit})" if unit else ""))
    value = items
    if length is not None and len(value) != length:
        raise FieldError(f"{where} = {value!r}: need {length} numbers, got {len(value)}")
    return tuple(float(v) for v in value)
