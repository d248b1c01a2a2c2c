"""TOML files written by a TOML writer and read back before the writer reports success.

Every TOML file the tool writes (a design's ``[design]`` table, a lookup's candidates, a designed
leg) goes through :func:`write_toml`: the document is serialised by ``tomli_w`` (every string
escaped as TOML requires, so a name with a newline, a quote or a control character stays one
value), the comments that open the file are made one line each (:func:`comment`), the file is
replaced atomically (:func:`~dpfexplore.io.files.atomic_write`), parsed back by the bounded
reader (:func:`~dpfexplore.io.toml_fields.read_toml`) and compared with what was meant; a
difference is an error naming the file and the first key that differs.

Values are normalised first (:func:`toml_ready`): NumPy scalars become Python numbers, tuples
become lists, a key whose value is ``None`` is left out and ``None`` inside a list is written as
the string ``"none"`` (TOML has no null).
"""

from __future__ import annotations

import errno
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import tomli_w

from .files import atomic_write
from .toml_fields import read_toml

__all__ = ["TomlWriteError", "comment", "toml_document", "toml_ready", "write_toml"]


class TomlWriteError(OSError):
    """A TOML file that could not be written as meant: an I/O error (``EIO``) naming the file.

    ``str()`` is one line naming the file; :attr:`filename` is the file.
    """

    def __init__(self, path: Path, why: str) -> None:
        super().__init__(errno.EIO, why, str(path))

    def __str__(self) -> str:
        return f"{self.filename}: {self.strerror}"


def toml_ready(value: Any) -> Any:
    """``value`` as plain Python values ``tomli_w`` writes (see the module docstring).

    Raises
    ------
    TypeError
        For a value TOML has no form for here (naming its type).
    """
    if isinstance(value, Mapping):
        return {str(k): toml_ready(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return ["none" if v is None else toml_ready(v) for v in value]
    if isinstance(value, (bool, str)):
        return value
    if hasattr(value, "dtype") and getattr(value, "shape", None) == ():  # a NumPy scalar
        value = value.item()
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    raise TypeError(f"{type(value).__name__} has no TOML form here")


def comment(text: str) -> str:
    """``text`` as one TOML comment line: a hash, a space and the text, control characters escaped.

    TOML comments may hold no control character but tab; a newline would end the comment and
    start a line of the document. Such characters (and lone surrogates, which UTF-8 cannot
    carry) are written as a backslash, ``u`` and four hex digits.
    """
    out = []
    for ch in str(text):
        code = ord(ch)
        if ch == "\t" or (ch.isprintable() and not 0xD800 <= code <= 0xDFFF):
            out.append(ch)
        else:
            out.append(f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}")
    return "# " + "".join(out)


def toml_document(data: Mapping[str, Any], comments: Sequence[str] = ()) -> str:
    """The TOML text of ``data`` (normalised by :func:`toml_ready`), opened by ``comments``."""
    head = "".join(comment(c) + "\n" for c in comments)
    return head + tomli_w.dumps(toml_ready(data))


def write_toml(
    path: str | Path,
    data: Mapping[str, Any],
    comments: Sequence[str] = (),
    *,
    kind: str = "toml",
) -> Path:
    """Write ``data`` as a TOML file, atomically, and read it back; returns the path.

    Parameters
    ----------
    path : str or Path
    data : mapping
        The document: tables as mappings.
    comments : sequence of str
        Lines that open the file, each written as one comment (:func:`comment`).
    kind : str
        The file's kind in :data:`~dpfexplore.io.files.SIZE_LIMITS`: it is read back within
        that kind's limit, as its readers will read it.

    Raises
    ------
    TomlWriteError
        If the file read back is not the document meant (naming the file and the first key
        that differs); the file is then removed.
    OSError
        As the write raises it (a full disk: the previous file, if any, is untouched).
    """
    path = Path(path)
    meant = toml_ready(data)
    atomic_write(path, toml_document(meant, comments).encode("utf-8"))
    try:
        back = read_toml(path, kind)
    except ValueError as exc:
        path.unlink(missing_ok=True)
        raise TomlWriteError(path, f"written, it does not read back ({exc})") from None
    key = _first_difference(meant, back)
    if key is not None:
        path.unlink(missing_ok=True)
        raise TomlWriteError(path, f"written, it reads back differently at {key or 'the top'}")
    return path


def _first_difference(meant: Any, back: Any, where: str = "") -> str | None:
    """The dotted key where ``back`` differs from ``meant`` (NaN equals NaN), None if nowhere."""
    if isinstance(meant, dict):
        if not isinstance(back, dict) or set(meant) != set(back):
            return where
        for key, value in meant.items():
            found = _first_difference(value, back[key], f"{where}.{key}" if where else key)
            if found is not None:
                return found
        return None
    if isinstance(meant, list):
        if not isinstance(back, list) or len(meant) != len(back):
            return where
        for i, (a, b) in enumerate(zip(meant, back, strict=True)):
            found = _first_difference(a, b, f"{where}[{i}]")
            if found is not None:
                return found
        return None
    same_type = type(meant) is type(back)
    if isinstance(meant, float) and same_type and math.isnan(meant) and math.isnan(back):
        return None
    return None if same_type and meant == back else where
