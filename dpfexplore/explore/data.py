"""A sweep dataset held in memory for the explorer: the columns the page draws and filters.

:func:`load_dataset` reads a sweep directory through the store's verified readers (every chunk
checked against the manifest's SHA-256, :func:`~dpfexplore.sweep.storage.store.read_results`)
and keeps, as NumPy arrays, the tip, the row identity (design, ``N``, state, status), the
material (from ``E`` and ``nu``) and every numeric output column the dataset holds (stiffness,
curvature, energies, the smallest eigenvalue, reset times). Everything that can be wrong with a
dataset is found here, before a server starts: a path that is not a sweep directory, a
tampered or missing chunk, an incomplete sweep, a dataset without tip columns or without rows.

:class:`Filters` says which rows the page shows; :meth:`ExploreData.mask` evaluates it in one
pass of NumPy comparisons (no expression is ever run as code).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..io.commits import StoreError
from ..model.constants_set import ConstantsSet
from ..model.design import MATERIALS
from ..model.status import Status
from ..sweep.storage.datasets import DatasetInfo, dataset_info
from ..sweep.storage.store import read_results, read_schema

__all__ = [
    "COLOUR_CATEGORIES",
    "TIP_COLUMNS",
    "DatasetError",
    "ExploreData",
    "Filters",
    "load_dataset",
    "material_of",
    "parse_state_pattern",
]

#: The columns every explored dataset must hold: the tip node's position (mm).
TIP_COLUMNS = ("tip_x", "tip_y")
#: Columns that colour the map by category rather than by value.
COLOUR_CATEGORIES = ("n_units", "state", "status")
#: Identity columns read besides the tip.
_IDENTITY = ("design_id", "n_units", "requested", "requested_bits", "status", "E", "nu")
#: Numeric columns not offered as filters or colours (identity, design variables).
_NOT_OUTPUTS = re.compile(
    r"(design_id|n_units|sample|requested|found|status|dyn_status|[HU]\w*_\d+)$"
)
#: Name of a material that is none of the presets.
OTHER_MATERIAL = "other"


class DatasetError(ValueError):
    """A dataset the explorer cannot show; the message is one line naming the path."""


def material_of(E: NDArray, nu: NDArray) -> tuple[NDArray[np.int8], tuple[str, ...]]:
    """Each row's material preset (an index into the returned names), by ``E`` and ``nu``.

    Rows matching no preset get the name ``"other"``.
    """
    names = [*MATERIALS, OTHER_MATERIAL]
    code = np.full(E.shape, len(names) - 1, dtype=np.int8)
    for i, material in enumerate(MATERIALS.values()):
        code[np.isclose(E, material.E, rtol=1e-12) & np.isclose(nu, material.nu, rtol=1e-12)] = i
    return code, tuple(names)


def parse_state_pattern(text: str) -> re.Pattern | None:
    """A state pattern (``"1*0"``: unit 1 inverted, unit 2 any, unit 3 not) as a regex.

    ``0``/``1`` fix a unit, ``*`` or ``x`` leave it free; the pattern fixes ``N`` by its length.
    An empty pattern matches every state (None).

    Raises
    ------
    ValueError
        Naming the pattern when it holds anything else.
    """
    text = text.strip()
    if not text:
        return None
    if not re.fullmatch(r"[01*xX]+", text):
        raise ValueError(f"state pattern {text!r}: use 0, 1 and * (any), unit 1 first, e.g. 1*0")
    return re.compile(re.sub(r"[*xX]", "[01]", text) + r"\Z")


@dataclass(frozen=True)
class Filters:
    """Which rows the page shows.

    Attributes
    ----------
    n_units : tuple of int or None
        Numbers of units kept (None: all).
    material : str or None
        A material name (:data:`~dpfexplore.model.design.MATERIALS`, or ``"other"``).
    state : str
        State pattern (:func:`parse_state_pattern`; empty: any state).
    statuses : tuple of str or None
        Status labels kept (None: all).
    ranges : mapping of str to (float, float)
        Closed interval per numeric column, in the column's unit; rows with a NaN there fail.
    """

    n_units: tuple[int, ...] | None = None
    material: str | None = None
    state: str = ""
    statuses: tuple[str, ...] | None = None
    ranges: Mapping[str, tuple[float, float]] = field(default_factory=dict)


@dataclass
class ExploreData:
    """The arrays of one dataset that the explorer draws and filters (one entry per row).

    Attributes
    ----------
    root : Path
    info : DatasetInfo
    constants : ConstantsSet
        The set the rows were computed under (checked against ``--constants``).
    tip : ndarray of shape (n, 2), mm
    design_id, n_units, requested : ndarray of int64, shape (n,)
    state : ndarray of str, shape (n,)
        Requested state, unit 1 first.
    status : ndarray of int8, shape (n,)
    material : ndarray of int8, shape (n,)
        Index into :attr:`materials`.
    materials : tuple of str
    columns : dict of str to ndarray of float64
        Numeric output columns (stiffness, curvature, ...), by name.
    units : dict of str to str
        Unit of each of :attr:`columns` (from the dataset's schema).
    """

    root: Path
    info: DatasetInfo
    constants: ConstantsSet
    tip: NDArray[np.float64]
    design_id: NDArray[np.int64]
    n_units: NDArray[np.int64]
    requested: NDArray[np.int64]
    state: NDArray
    status: NDArray[np.int8]
    material: NDArray[np.int8]
    materials: tuple[str, ...]
    columns: dict[str, NDArray[np.float64]]
    units: dict[str, str]

    def __len__(self) -> int:
        return self.tip.shape[0]

    @property
    def n_values(self) -> tuple[int, ...]:
        """Numbers of units present."""
        return tuple(int(n) for n in np.unique(self.n_units))

    @property
    def status_labels(self) -> tuple[str, ...]:
        """Labels of the statuses present."""
        return tuple(Status(int(code)).label for code in np.unique(self.status))

    @property
    def materials_present(self) -> tuple[str, ...]:
        """Material names present."""
        return tuple(self.materials[int(code)] for code in np.unique(self.material))

    def finite_range(self, name: str) -> tuple[float, float]:
        """Smallest and largest finite value of a numeric column (NaN, NaN if none)."""
        values = self.columns[name]
        finite = values[np.isfinite(values)]
        if finite.size == 0:
            return math.nan, math.nan
        return float(finite.min()), float(finite.max())

    def mask(self, filters: Filters) -> NDArray[np.bool_]:
        """Rows passing ``filters``.

        Raises
        ------
        ValueError
            Naming the filter: an unknown column, material or status, a bad state pattern.
        """
        keep = np.ones(len(self), dtype=bool)
        if filters.n_units is not None:
            keep &= np.isin(self.n_units, np.asarray(filters.n_units, dtype=np.int64))
        if filters.material is not None:
            if filters.material not in self.materials:
                raise ValueError(
                    f"material {filters.material!r}: one of {', '.join(self.materials)}"
                )
            keep &= self.material == self.materials.index(filters.material)
        pattern = parse_state_pattern(filters.state)
        if pattern is not None:
            states, inverse = np.unique(self.state, return_inverse=True)
            hits = np.array([bool(pattern.match(s)) for s in states], dtype=bool)
            keep &= hits[inverse]
        if filters.statuses is not None:
            labels = {s.label: int(s) for s in Status}
            unknown = [s for s in filters.statuses if s not in labels]
            if unknown:
                raise ValueError(f"status {unknown[0]!r}: one of {', '.join(labels)}")
            keep &= np.isin(self.status, [labels[s] for s in filters.statuses])
        for name, (low, high) in filters.ranges.items():
            if name not in self.columns:
                raise ValueError(f"column {name!r}: one of {', '.join(self.columns)}")
            values = self.columns[name]
            keep &= (values >= low) & (values <= high)
        return keep


def _numeric_outputs(root: Path) -> dict[str, str]:
    """Numeric output columns of the dataset's schema, with their units."""
    import pyarrow as pa

    out = {}
    for f in read_schema(root):
        numeric = pa.types.is_floating(f.type) or pa.types.is_integer(f.type)
        if not numeric or f.name in TIP_COLUMNS or _NOT_OUTPUTS.match(f.name):
            continue
        if f.name in ("E", "nu", "t", "t_lim", "r_b", "t_ch"):
            continue
        unit = (f.metadata or {}).get(b"unit", b"").decode()
        out[f.name] = unit
    return out


def load_dataset(
    root: str | Path, *, constants: ConstantsSet | None = None, verify: bool = True
) -> ExploreData:
    """Read a sweep dataset for the explorer, every chunk checked.

    Parameters
    ----------
    root : path
        Sweep directory.
    constants : ConstantsSet, optional
        A user's ``--constants``: must be the dataset's set.
    verify : bool
        Check every chunk against the manifest's SHA-256 (the default).

    Raises
    ------
    DatasetError
        One line naming the path: not a sweep directory, a chunk missing or changed since it
        was committed, an incomplete sweep, no tip columns, another constants set, no rows.
    """
    root = Path(root)
    try:
        info = dataset_info(root)
        constants = info.constants_set(constants)
        schema = read_schema(root)
    except StoreError as exc:
        raise DatasetError(str(exc)) from None
    if not info.complete:
        raise DatasetError(
            f"{root}: incomplete dataset ({info.designs_committed} of {info.designs_planned} "
            "designs committed): finish its sweep (dpfexplore sweep JOB --out DIR --resume) first"
        )
    missing = [c for c in (*TIP_COLUMNS, *_IDENTITY) if c not in schema.names]
    if missing:
        raise DatasetError(
            f"{root}: no {', '.join(missing)} column{'s' if len(missing) > 1 else ''}: the "
            "explorer draws the tip of every design-state row (a finger sweep's dataset)"
        )
    outputs = _numeric_outputs(root)
    try:
        frame = read_results(root, columns=[*TIP_COLUMNS, *_IDENTITY, *outputs], verify=verify)
    except StoreError as exc:
        raise DatasetError(str(exc)) from None
    if len(frame) == 0:
        raise DatasetError(f"{root}: the dataset holds no rows")
    E, nu = frame["E"].to_numpy(float), frame["nu"].to_numpy(float)
    material, names = material_of(E, nu)
    return ExploreData(
        root=root,
        info=info,
        constants=constants,
        tip=np.ascontiguousarray(frame[list(TIP_COLUMNS)].to_numpy(float)),
        design_id=frame["design_id"].to_numpy(np.int64),
        n_units=frame["n_units"].to_numpy(np.int64),
        requested=frame["requested"].to_numpy(np.int64),
        state=frame["requested_bits"].astype(str).to_numpy(),
        status=frame["status"].to_numpy(np.int8),
        material=material,
        materials=names,
        columns={name: frame[name].to_numpy(float, na_value=np.nan) for name in outputs},
        units=outputs,
    )


def count_by(values: NDArray, keep: NDArray[np.bool_], keys: Sequence) -> dict:
    """Rows kept per key (``values == key``), for the counts beside the filters."""
    return {key: int(np.count_nonzero(keep & (values == key))) for key in keys}
