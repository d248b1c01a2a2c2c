"""Measurements of printed fingers: the file format, its records and its reader.

A measurement file is TOML, one ``[[finger]]`` table per printed finger; a lab writes one for its
own prints, and the package ships the paper's (``dpfexplore/data/measurements/paper.toml``,
:func:`packaged_measurements`). Units: mm, N/mm, MPa. Tips are in the finger frame of MODEL.md
§5: base at the origin, dome line on ``y = 0``, the finger along ``+x``, curling toward ``+y``.

File format (``format = "dpfexplore-measurements/1"``)::

    format = "dpfexplore-measurements/1"     # required, first
    title = "..."                            # optional
    source = "..."                           # optional: where the measurements come from

    [[finger]]
    name = "cheetah-target-2"                # required, unique in the file
    material = "cheetah-95a"                 # a material preset (dpfexplore.model.materials) ...
    # E = 26.0                               # ... or E (MPa) and optionally nu; material is then
    # nu = 0.35                              #     a free label
    H = [4.52, 3.93, 3.63]                   # mm, unit 1 (the base) first; N = len(H)
    U_sep = 1.10                             # mm, one value or one per unit
    U_L = 7.28                               # mm, one value or one per unit
    t = 0.83                                 # mm
    t_lim = 1.59                             # mm
    # r_b = 5.0, t_ch = 1.0                  # mm, optional (the design defaults)
    # design = "prints/finger-2.toml"        # instead of the keys above: a design file's
    #                                        # [design] table (relative to this file)
    state = "111"                            # required: N characters 0/1, unit 1 first
    tip = [25.17, 16.55]                     # measured tip (x, y), mm ...
    # tip_uncertainty = 0.5                  #   optional, mm: one value or [u_x, u_y]
    # stiffness = 0.30                       # ... and/or the measured tip stiffness, N/mm
    # stiffness_uncertainty = 0.02           #   optional, N/mm
    # reference_tip = [24.7, 19.5]           # optional: another model's tip, shown beside ours
    # target = [25.0, 20.0]                  # optional: the tip the design aimed at, mm

    [finger.provenance]                      # required: one string, or a table whose keys
    tip = "SI Table experimental_val ..."    # are the finger's keys (``design``: its geometry)

A finger gives a ``tip``, a ``stiffness`` or both. The stiffness is the tip stiffness of
MODEL.md §7 (a force normal to the last limiting-layer segment), of the stated ``state``.

Reading (:func:`read_measurements`) is all or nothing: the file is read only if it is a regular
file of at most :data:`MAX_BYTES` (a design file it names: :data:`MAX_DESIGN_BYTES`), and any
problem (a missing key, an unknown material, a non-finite value, a state of the wrong length, a
name used twice, ...) is one :class:`MeasurementError` line naming the file, the finger (its row
in ``[[finger]]``, 1 first, and its name) and the key, e.g.
``paper.toml: finger 7 ('cheetah-target-2'), state = '11': need 3 characters 0/1 (N = len(H)),
unit 1 first``. :func:`measurements_toml` writes the records back (:mod:`.writer`).
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..io.files import SIZE_LIMITS, BoundedReadError, read_bounded
from ..model.design import Design
from ..model.materials import MATERIALS

__all__ = [
    "FORMAT",
    "MAX_BYTES",
    "MAX_DESIGN_BYTES",
    "PACKAGED_DIR",
    "Measurement",
    "MeasurementError",
    "MeasurementFile",
    "packaged_measurements",
    "read_measurements",
]

#: The format line a measurement file starts with.
FORMAT = "dpfexplore-measurements/1"
#: Largest measurement file read (bytes): :data:`~dpfexplore.io.files.SIZE_LIMITS`.
MAX_BYTES = SIZE_LIMITS["measurements"].bytes
#: Largest design file a finger may name (bytes).
MAX_DESIGN_BYTES = SIZE_LIMITS["design"].bytes
#: Folder of the packaged measurement files.
PACKAGED_DIR = Path(__file__).resolve().parent.parent / "data" / "measurements"

#: Keys of a finger's inline design (besides ``material``), as :meth:`Design.from_dict` takes them.
DESIGN_KEYS = ("H", "U_L", "U_sep", "t", "t_lim", "r_b", "t_ch", "E", "nu")
_REQUIRED_DESIGN = ("H", "U_L", "U_sep", "t", "t_lim")
FINGER_KEYS = (
    "name",
    "provenance",
    "material",
    *DESIGN_KEYS,
    "design",
    "state",
    "tip",
    "tip_uncertainty",
    "stiffness",
    "stiffness_uncertainty",
    "reference_tip",
    "target",
)


class MeasurementError(ValueError):
    """A measurement file that cannot be used; the message is one line naming file, finger, key."""


@dataclass(frozen=True)
class Measurement:
    """One printed finger and what was measured on it.

    Attributes
    ----------
    name : str
    design : Design
        Its geometry and material (under the paper's constants set; :func:`~.validate.validate`
        evaluates it under each set it is given).
    state : str
        The inversion vector measured, unit 1 first (``"1111"``: all units inverted).
    material : str or None
        The material preset's key (``"cheetah-95a"``), or the free label given with ``E``.
    tip : (float, float) or None, mm
        Measured tip ``(x, y)`` in the frame of MODEL.md §5.
    tip_uncertainty : (float, float) or None, mm
        Its uncertainty per coordinate, when stated.
    stiffness : float or None, N/mm
        Measured tip stiffness of ``state``.
    stiffness_uncertainty : float or None, N/mm
    reference_tip : (float, float) or None, mm
        Another model's tip for this finger (the paper's own), shown beside the predictions.
    target : (float, float) or None, mm
        The tip the design aimed at.
    provenance : dict of str to str
        Where each value comes from: a finger key (``"design"`` for the geometry) to a source;
        ``{"": text}`` when the file gives one string for all.
    source : str
        The file it was read from ("" when made in Python); not compared.
    """

    name: str
    design: Design
    state: str
    material: str | None = None
    tip: tuple[float, float] | None = None
    tip_uncertainty: tuple[float, float] | None = None
    stiffness: float | None = None
    stiffness_uncertainty: float | None = None
    reference_tip: tuple[float, float] | None = None
    target: tuple[float, float] | None = None
    provenance: dict[str, str] = field(default_factory=dict, hash=False)
    source: str = field(default="", compare=False)

    @property
    def material_label(self) -> str:
        """How tables name the material: the preset's trade name, the label, or ``E = .. MPa``."""
        preset = MATERIALS.get(self.material or "")
        if preset is not None and (preset.E, preset.nu) == (self.design.E, self.design.nu):
            return preset.name
        return self.material or f"E = {self.design.E:g} MPa"

    @property
    def base_distance(self) -> float | None:
        """Distance of the measured tip from the base (mm): the scale of relative distances."""
        return None if self.tip is None else math.hypot(*self.tip)


@dataclass(frozen=True)
class MeasurementFile:
    """The fingers of one measurement file, with its header and checksum.

    Attributes
    ----------
    path : str
    fingers : tuple of Measurement
    title, source : str
        The file's optional header strings ("" when absent).
    sha256 : str
        SHA-256 of the file's bytes (of the TOML :func:`measurements_toml` writes, for records
        made in Python).
    """

    path: str
    fingers: tuple[Measurement, ...]
    title: str = ""
    source: str = ""
    sha256: str = ""


def packaged_measurements() -> list[Path]:
    """The measurement files that ship with the package (``data/measurements/*.toml``)."""
    return sorted(PACKAGED_DIR.glob("*.toml"))


def read_measurements(path: str | Path) -> MeasurementFile:
    """Read and check a measurement file (format in the module docstring).

    Raises
    ------
    MeasurementError
        One line naming the file, the finger and the key; nothing is returned in part.
    """
    path = Path(path)
    raw = _read(path, MAX_BYTES, "measurement file")
    try:
        document = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise MeasurementError(f"{path}: not a text file (a measurement file is TOML)") from None
    except (ValueError, RecursionError) as exc:  # not TOML, or an integer too long to read
        raise MeasurementError(f"{path}: not valid TOML ({exc})") from None
    header = {"format", "title", "source", "finger"}
    for key in document:
        if key not in header:
            raise MeasurementError(
                f"{path}: {key}: unknown key; known: {', '.join(sorted(header))} "
                "(a finger's keys go in a [[finger]] table)"
            )
    if document.get("format") != FORMAT:
        found = f" = {document['format']!r}" if "format" in document else ": missing"
        raise MeasurementError(
            f'{path}: format{found}; a measurement file says format = "{FORMAT}"'
        )
    for key in ("title", "source"):
        if not isinstance(document.get(key, ""), str):
            raise MeasurementError(f"{path}: {key} = {document[key]!r}: must be a string")
    entries = document.get("finger")
    if not isinstance(entries, list) or not entries:
        raise MeasurementError(f"{path}: no [[finger]] tables (one per printed finger)")
    fingers: list[Measurement] = []
    for row, entry in enumerate(entries, start=1):
        finger = _finger(entry, row, path)
        if any(f.name == finger.name for f in fingers):
            raise MeasurementError(
                f"{path}: finger {row} ({finger.name!r}), name: used by an earlier finger"
            )
        fingers.append(finger)
    return MeasurementFile(
        path=str(path),
        fingers=tuple(fingers),
        title=document.get("title", ""),
        source=document.get("source", ""),
        sha256=hashlib.sha256(raw).hexdigest(),
    )


def _read(path: Path, limit: int, what: str) -> bytes:
    try:
        return read_bounded(path, limit)
    except FileNotFoundError:
        raise MeasurementError(f"{path}: no such {what}") from None
    except BoundedReadError as exc:
        raise MeasurementError(f"{exc} (a {what})") from None
    except OSError as exc:
        raise MeasurementError(f"{path}: cannot read ({exc.strerror or exc})") from None


class _Finger:
    """The context of one finger's checks: its file, row and name for every message."""

    def __init__(self, entry: Mapping[str, Any], row: int, path: Path) -> None:
        self.entry, self.row, self.path = entry, row, path
        self.name: str | None = None

    def where(self) -> str:
        """``FILE: finger ROW ('NAME')``: how every message starts."""
        return f"{self.path}: finger {self.row}" + (f" ({self.name!r})" if self.name else "")

    def fail(self, key: str, problem: str, *, show: bool = True) -> MeasurementError:
        value = f" = {self.entry[key]!r}" if show and key in self.entry else ""
        return MeasurementError(f"{self.where()}, {key}{value}: {problem}")

    def number(self, key: str, value: Any, *, minimum: float | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, "must be a number")
        if not math.isfinite(value):
            raise self.fail(key, "not a finite number")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"must be >= {minimum:g}")
        return float(value)

    def point(self, key: str) -> tuple[float, float] | None:
        value = self.entry.get(key)
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(key, "must be [x, y] in mm")
        x, y = (self.number(key, v) for v in value)
        return x, y


def _finger(entry: Any, row: int, path: Path) -> Measurement:
    f = _Finger(entry if isinstance(entry, Mapping) else {}, row, path)
    if not isinstance(entry, Mapping):
        raise MeasurementError(f"{path}: finger {row}: must be a [[finger]] table")
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        raise f.fail("name", "missing" if name is None else "must be a non-empty string")
    f.name = name
    for key in entry:
        if key not in FINGER_KEYS:
            raise f.fail(key, f"unknown key; known: {', '.join(FINGER_KEYS)}")
    design, material = _design(f)
    state = entry.get("state")
    if state is None:
        raise f.fail("state", "missing (the measured state, e.g. '1111': unit 1 first)")
    n = design.n_units
    if not isinstance(state, str) or len(state) != n or set(state) - {"0", "1"}:
        raise f.fail("state", f"need {n} characters 0/1 (N = len(H)), unit 1 first")
    tip, stiffness = f.point("tip"), entry.get("stiffness")
    if tip is None and stiffness is None:
        raise f.fail("tip", "missing: give the measured tip, the stiffness or both")
    if stiffness is not None:
        stiffness = f.number("stiffness", stiffness)
        if stiffness <= 0.0:
            raise f.fail("stiffness", "must be > 0 N/mm")
    return Measurement(
        name=name,
        design=design,
        state=state,
        material=material,
        tip=tip,
        tip_uncertainty=_uncertainty(f, "tip_uncertainty", "tip", pair=True),
        stiffness=stiffness,
        stiffness_uncertainty=_uncertainty(f, "stiffness_uncertainty", "stiffness", pair=False),
        reference_tip=f.point("reference_tip"),
        target=f.point("target"),
        provenance=_provenance(f),
        source=str(path),
    )


def _design(f: _Finger) -> tuple[Design, str | None]:
    """The finger's design and material key (inline, or from the design file it names)."""
    entry = f.entry
    if "design" in entry:
        inline = [k for k in ("material", *DESIGN_KEYS) if k in entry]
        if inline:
            raise f.fail(inline[0], "give the design inline or as a design file, not both")
        table, base = _design_file(f)
    else:
        table, base = dict(entry), f.path.parent
    values = {k: table[k] for k in DESIGN_KEYS if k in table}
    for key in _REQUIRED_DESIGN:
        if key not in values:
            raise f.fail(key, "missing design key", show=False)
    for key, value in values.items():
        for v in value if isinstance(value, list) else [value]:
            f.number(key, v)
    material = table.get("material")
    if material is not None and not isinstance(material, str):
        raise f.fail("material", "must be a string")
    if "E" not in values:
        if material is None:
            raise f.fail("material", f"missing: name one of {', '.join(MATERIALS)}, or give E")
        if material.lower() not in MATERIALS:
            raise f.fail(
                "material",
                f"unknown material; known: {', '.join(MATERIALS)} (or give E and nu)",
            )
        material = material.lower()
        preset = MATERIALS[material]
        values["E"] = preset.E
        values.setdefault("nu", preset.nu)
    try:
        design = Design.from_dict({**values, "name": f.name}, base=base)
    except ValueError as exc:  # its message starts with the key (H[unit 2] = 6.0 mm: ...)
        source = f"design {entry['design']!r}: " if "design" in entry else ""
        raise MeasurementError(f"{f.where()}, {source}{exc}") from None
    return design, material


def _design_file(f: _Finger) -> tuple[dict[str, Any], Path]:
    text = f.entry["design"]
    if not isinstance(text, str) or not text.strip():
        raise f.fail("design", "must be the path of a design file (TOML with a [design] table)")
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = f.path.parent / path
    try:
        raw = _read(path, MAX_DESIGN_BYTES, "design file")
        document = tomllib.loads(raw.decode("utf-8"))
    except MeasurementError as exc:
        raise f.fail("design", str(exc)) from None
    except (ValueError, RecursionError) as exc:  # not UTF-8, not TOML, an integer too long
        raise f.fail("design", f"{path}: not valid TOML ({exc})") from None
    table = document.get("design")
    if not isinstance(table, Mapping):
        raise f.fail("design", f"{path}: no [design] table")
    unknown = [k for k in table if k not in ("material", "name", *DESIGN_KEYS)]
    if unknown:
        raise f.fail(
            "design",
            f"{path}: [design] {unknown[0]}: not taken here (validate evaluates each "
            "constants set it is given; give the geometry and the material only)",
        )
    if "material" in table and "E" in table:
        raise f.fail("design", f"{path}: [design] gives material and E; give one")
    return dict(table), path.parent


def _uncertainty(f: _Finger, key: str, of: str, *, pair: bool) -> Any:
    value = f.entry.get(key)
    if value is None:
        return None
    if of not in f.entry:
        raise f.fail(key, f"given without {of}")
    if pair and isinstance(value, list):
        if len(value) != 2:
            raise f.fail(key, "must be one number or [u_x, u_y] in mm")
        ux, uy = (f.number(key, v, minimum=0.0) for v in value)
        return ux, uy
    value = f.number(key, value, minimum=0.0)
    return (value, value) if pair else value


def _provenance(f: _Finger) -> dict[str, str]:
    value = f.entry.get("provenance")
    if value is None:
        raise f.fail("provenance", "missing: say where the values come from (a string, or a table)")
    if isinstance(value, str) and value.strip():
        return {"": value}
    if not isinstance(value, Mapping) or not value:
        raise f.fail("provenance", "must be a non-empty string or a table of strings")
    known = {k for k in FINGER_KEYS if k not in ("name", "provenance")}
    for key, text in value.items():
        if key not in known:
            raise f.fail("provenance", f"{key}: not a key of a finger", show=False)
        if not isinstance(text, str) or not text.strip():
            raise f.fail("provenance", f"{key}: must be a non-empty string", show=False)
    return dict(value)
