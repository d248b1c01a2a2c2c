"""Measurement files written from records: the TOML that :func:`~.fingers.read_measurements` reads.

Values are written by a writer for TOML's own literals (strings escaped as TOML requires, floats
at full precision: ``repr`` of a float reads back to the same float), never by formatting text
into a template; :func:`write_measurements` writes atomically and reads the file back before it
reports success, so what it returns is what a reader gets.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..io.files import atomic_write
from ..model.design import DEFAULTS
from ..model.materials import MATERIALS
from .fingers import FORMAT, Measurement, MeasurementError, MeasurementFile, read_measurements

__all__ = ["measurements_toml", "toml_literal", "write_measurements"]


def toml_literal(value: Any) -> str:
    """A TOML literal of a string, a finite number, a bool or a list of them.

    Raises
    ------
    ValueError
        For a non-finite float or a type TOML has no literal for here.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        # JSON's escapes are TOML's, except that TOML also escapes DEL and cannot read the
        # surrogate pairs JSON writes for characters beyond U+FFFF (kept literal: UTF-8)
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{value!r}: a measurement file holds finite numbers only")
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    raise ValueError(f"{type(value).__name__}: no TOML literal for it here")


def _key(name: str) -> str:
    """A bare key when TOML allows one, else a quoted key."""
    bare = name and all(c.isascii() and (c.isalnum() or c in "_-") for c in name)
    return name if bare else toml_literal(name)


def _per_unit(values: tuple[float, ...]) -> float | list[float]:
    return values[0] if len(set(values)) == 1 else list(values)


def _finger_lines(m: Measurement) -> list[str]:
    d = m.design
    values: dict[str, Any] = {"name": m.name}
    preset = MATERIALS.get(m.material or "")
    if preset is not None and (preset.E, preset.nu) == (d.E, d.nu):
        values["material"] = m.material
    else:
        if m.material is not None:
            values["material"] = m.material
        values.update(E=d.E, nu=d.nu)
    values.update(H=list(d.H), U_sep=_per_unit(d.U_sep), U_L=_per_unit(d.U_L), t=d.t)
    values["t_lim"] = d.t_lim
    for name in ("r_b", "t_ch"):
        if getattr(d, name) != DEFAULTS[name]:
            values[name] = getattr(d, name)
    values["state"] = m.state
    optional = {
        "tip": m.tip,
        "tip_uncertainty": m.tip_uncertainty,
        "stiffness": m.stiffness,
        "stiffness_uncertainty": m.stiffness_uncertainty,
        "reference_tip": m.reference_tip,
        "target": m.target,
    }
    values.update({k: v for k, v in optional.items() if v is not None})
    if m.provenance.keys() == {""}:
        values["provenance"] = m.provenance[""]
    lines = ["[[finger]]", *(f"{_key(k)} = {toml_literal(v)}" for k, v in values.items())]
    if m.provenance and m.provenance.keys() != {""}:
        lines += ["", "[finger.provenance]"]
        lines += [f"{_key(k)} = {toml_literal(v)}" for k, v in m.provenance.items()]
    return lines


def measurements_toml(fingers: Sequence[Measurement], *, title: str = "", source: str = "") -> str:
    """The measurement file of ``fingers`` (format in :mod:`.fingers`) as TOML text."""
    lines = [f"format = {toml_literal(FORMAT)}"]
    if title:
        lines.append(f"title = {toml_literal(title)}")
    if source:
        lines.append(f"source = {toml_literal(source)}")
    for m in fingers:
        lines += ["", *_finger_lines(m)]
    return "\n".join(lines) + "\n"


def write_measurements(
    path: str | Path, fingers: Sequence[Measurement], *, title: str = "", source: str = ""
) -> MeasurementFile:
    """Write ``fingers`` as a measurement file (atomically) and return it as read back.

    Raises
    ------
    MeasurementError
        If the file read back does not hold the records given (a value TOML cannot carry).
    ValueError
        If a value has no TOML literal (a non-finite number).
    """
    path = Path(path)
    atomic_write(path, measurements_toml(fingers, title=title, source=source))
    written = read_measurements(path)
    if written.fingers != tuple(fingers) or (written.title, written.source) != (title, source):
        raise MeasurementError(f"{path}: the file read back differs from the records written")
    return written
