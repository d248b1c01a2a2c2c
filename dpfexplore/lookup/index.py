"""Nearest-neighbour index over output columns of a sweep dataset, kept beside the dataset.

A :class:`LookupIndex` holds, for every usable row of a sweep directory (status ``ok``: the
requested state exists, and every indexed column finite), the values of the chosen output
columns (``tip_x, tip_y`` by default; any numeric columns) and where the row lives (its
``design_id``, state, ``n_units``, chunk file and position in that file). Distances are Euclidean
in *scaled* coordinates ``value / scale``, one scale per column in the column's unit (1 mm for the
tip): a query of ``tip_x, tip_y, stiffness`` with scales ``1, 1, 0.01`` counts 0.01 N/mm of
stiffness like 1 mm of tip position.

Rows are sorted by ``(n_units, requested state, design_id)``, so every number of units, and every
state within it, is one contiguous slice; each slice that a query needs gets its own
:class:`scipy.spatial.cKDTree` (built once, on first use for the per-state slices of a
multi-state dataset). A query over several ``N`` queries each slice and merges. A row filter (a
``--where`` expression) is applied exactly: the tree is asked for more neighbours until ``k`` rows
pass it, or a small filtered set is scanned directly.

Persistence (saved beside the dataset, verified on load, rebuilt when stale or damaged) is in
:mod:`dpfexplore.lookup.store`.

An index records the chunks it was read from (:class:`ChunkSource`: path, size and SHA-256 as
the manifest listed them when each was read) and whether those reads were verified against the
SHA-256 (:attr:`LookupIndex.verified`); only a verified index is ever saved.

A dataset that a sweep is still writing is indexed through its committed chunks only (the
manifest is the commit record); :attr:`LookupIndex.complete` says whether it was complete.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from ..model import status as st
from ..model.formatting import nums
from ..sweep.storage.datasets import DatasetInfo, dataset_info
from ..sweep.storage.store import read_schema

__all__ = [
    "DEFAULT_COLUMNS",
    "ChunkSource",
    "LookupIndex",
    "StaleIndexError",
    "build_index",
    "check_columns",
    "check_scales",
    "mask_of",
    "stale_reason",
]

#: Largest target accepted, in units of its column's scale: beyond it, squared distances
#: overflow double precision (1e300) and every row would be equally "infinitely" far.
MAX_SCALED_TARGET = 1e150

#: Columns indexed when none are named: the tip position (mm).
DEFAULT_COLUMNS = ("tip_x", "tip_y")
#: Filtered sets up to this size are scanned directly instead of asking the tree for more.
_SCAN_ROWS = 16384
#: Columns every index reads besides the indexed ones.
_ROW_COLUMNS = ("design_id", "n_units", "requested", "status")


class StaleIndexError(Exception):
    """A saved or loaded index no longer describes its dataset (the dataset changed).

    Attributes
    ----------
    reason : str
        One short clause saying why (``"it is stale: ..."``), for a note to the user.
    """

    def __init__(self, message: str, reason: str | None = None) -> None:
        super().__init__(message)
        self.reason = reason or message


@dataclass(frozen=True)
class ChunkSource:
    """A chunk an index was read from, as the dataset's manifest listed it at that time.

    Attributes
    ----------
    path : str
        Relative POSIX path inside the dataset (``N05/part-000012.parquet``).
    sha256 : str
        The manifest's SHA-256 of the file (hex).
    bytes : int
        The manifest's file size.
    """

    path: str
    sha256: str
    bytes: int


# ----------------------------------------------------------------------------- columns


def check_columns(root: Path, columns: Sequence[str]) -> tuple[str, ...]:
    """``columns`` as a tuple, or ValueError naming an unknown, non-numeric or repeated one."""
    columns = tuple(columns)
    if not columns:
        raise ValueError("columns = (): name at least one output column")
    if len(set(columns)) != len(columns):
        raise ValueError(f"columns = {list(columns)!r}: a column is named twice")
    schema = read_schema(root)
    for name in columns:
        if name not in schema.names:
            numeric = [f.name for f in schema if _numeric(f.type) and f.name not in _ROW_COLUMNS]
            raise ValueError(
                f"column {name!r}: not in the dataset; numeric columns: {', '.join(numeric)}"
            )
        if not _numeric(schema.field(name).type):
            raise ValueError(f"column {name!r}: not numeric ({schema.field(name).type})")
        if name in _ROW_COLUMNS:
            raise ValueError(f"column {name!r}: identifies rows; index an output column")
    return columns


def _numeric(dtype: pa.DataType) -> bool:
    return pa.types.is_floating(dtype) or pa.types.is_integer(dtype)


def check_scales(scales: ArrayLike | None, columns: Sequence[str]) -> NDArray[np.float64]:
    """One finite scale > 0 per column (default 1 each), or ValueError."""
    if scales is None:
        return np.ones(len(columns))
    values = np.asarray(scales, dtype=float).reshape(-1)
    if values.shape != (len(columns),):
        raise ValueError(
            f"scales = {nums(np.atleast_1d(scales))}: need {len(columns)} values, one per "
            f"column ({', '.join(columns)})"
        )
    if not np.all(np.isfinite(values) & (values > 0)):
        raise ValueError(f"scales = {values.tolist()!r}: every scale must be finite and > 0")
    return values


def stale_reason(
    files: Sequence[str], sources: Sequence[ChunkSource], checksum: str, info: DatasetInfo
) -> str | None:
    """Why an index read from ``sources`` no longer describes the dataset, or None.

    Stale when the dataset checksum differs from ``checksum``, or (``sources`` given) a chunk
    read is no longer committed with the SHA-256 and size it had, or chunks were committed since.
    """
    now = {r.path: r for r in info.records}
    changed = [
        s.path
        for s in sources
        if s.path not in now or (now[s.path].sha256, now[s.path].bytes) != (s.sha256, s.bytes)
    ]
    if sources and tuple(s.path for s in sources) != tuple(files):
        changed.append("its file list")
    added = bool(sources) and set(now) != set(files)
    if info.checksum == checksum and not changed and not added:
        return None
    detail = f"; changed: {changed[0][:80]}" if changed else ""
    return (
        f"it is stale: the dataset changed after it was built ({len(files)} chunk files then, "
        f"{len(info.chunks)} now{detail})"
    )


# ----------------------------------------------------------------------------- the index


@dataclass(eq=False)
class LookupIndex:
    """Nearest-neighbour index over ``columns`` of one sweep dataset (see the module docstring).

    Build with :func:`build_index`, or get a fresh one with :func:`open_index`.

    Attributes
    ----------
    root : Path
        The dataset directory.
    columns : tuple of str
        Indexed output columns.
    scales : ndarray of shape (d,)
        Scale of each column, in its unit; distances are Euclidean in ``value / scale``.
    points : ndarray of shape (n, d)
        Column values of the indexed rows (physical units).
    design_id, requested : ndarray of int64, shape (n,)
        Row identity: the design and the requested state (an integer, unit 1 = most significant
        bit; the row's state, since only ``ok`` rows are indexed).
    n_units : ndarray of int8, shape (n,)
    file, row : ndarray of int32, shape (n,)
        Chunk file (index into :attr:`files`) and position of the row in that file.
    files : tuple of str
        Relative paths of the chunk files the rows come from.
    checksum : str
        :func:`dataset_checksum` of the dataset the index was built from.
    complete : bool
        Whether that dataset was complete.
    rows_read : int
        Rows of the committed chunks (indexed or not).
    sources : tuple of ChunkSource
        The manifest records of :attr:`files` when they were read (same order); empty for an
        index assembled by hand, which :meth:`check` then judges by :attr:`checksum` alone.
    verified : bool
        Every chunk was read through a SHA-256 check against ``sources``. Only such an index
        is saved (:func:`~dpfexplore.lookup.store.save_index`).
    """

    root: Path
    columns: tuple[str, ...]
    scales: NDArray[np.float64]
    points: NDArray[np.float64]
    design_id: NDArray[np.int64]
    requested: NDArray[np.int64]
    n_units: NDArray[np.int8]
    file: NDArray[np.int32]
    row: NDArray[np.int32]
    files: tuple[str, ...]
    checksum: str
    complete: bool
    rows_read: int
    sources: tuple[ChunkSource, ...] = ()
    verified: bool = False
    _slices: dict[tuple, slice] = field(default_factory=dict, repr=False)
    _trees: dict[tuple, cKDTree] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.scales = check_scales(self.scales, self.columns)
        self._scaled = self.points / self.scales
        # Contiguous slices per N and per (N, state): rows are sorted by those keys.
        for key_cols in ((self.n_units,), (self.n_units, self.requested)):
            if not len(self):
                break
            keys = np.stack(key_cols, axis=1).astype(np.int64)
            change = np.flatnonzero(np.any(np.diff(keys, axis=0) != 0, axis=1)) + 1
            starts = np.concatenate([[0], change])
            stops = np.concatenate([change, [len(self)]])
            for a, b in zip(starts, stops, strict=True):
                self._slices[tuple(int(v) for v in keys[a])] = slice(int(a), int(b))
        # Eager trees per N: the query every lookup makes. Per-state trees follow on demand.
        for n in self.n_values:
            self._tree((n,))

    def __len__(self) -> int:
        return self.points.shape[0]

    @property
    def n_values(self) -> tuple[int, ...]:
        """Numbers of units with indexed rows."""
        return tuple(sorted(key[0] for key in self._slices if len(key) == 1))

    def states_of(self, n_units: int) -> tuple[int, ...]:
        """States (integers) with indexed rows at ``n_units``."""
        return tuple(sorted(key[1] for key in self._slices if len(key) == 2 and key[0] == n_units))

    def _tree(self, key: tuple) -> cKDTree:
        tree = self._trees.get(key)
        if tree is None:
            part = self._scaled[self._slices[key]]
            # Sliding-midpoint splits (balanced_tree=False) build several times faster than
            # median splits and query as fast on these smooth, dense point clouds.
            tree = cKDTree(part, leafsize=16, balanced_tree=False, compact_nodes=False)
            self._trees[key] = tree
        return tree

    def check(self, info: DatasetInfo | None = None) -> None:
        """Raise :class:`StaleIndexError` unless the dataset still holds what was indexed.

        The dataset's checksum must be the one recorded, and every chunk the rows were read
        from must be committed now with the SHA-256 it had when it was read.
        """
        info = info or dataset_info(self.root)
        reason = stale_reason(self.files, self.sources, self.checksum, info)
        if reason is not None:
            raise StaleIndexError(
                f"{self.root}: the lookup index of {', '.join(self.columns)}: {reason}; rebuild "
                "it (open_index, or dpfexplore lookup without --no-rebuild)",
                reason,
            )

    def with_scales(self, scales: ArrayLike | None) -> LookupIndex:
        """The same rows under other scales (new trees; the arrays are shared)."""
        return LookupIndex(
            root=self.root,
            columns=self.columns,
            scales=check_scales(scales, self.columns),
            points=self.points,
            design_id=self.design_id,
            requested=self.requested,
            n_units=self.n_units,
            file=self.file,
            row=self.row,
            files=self.files,
            checksum=self.checksum,
            complete=self.complete,
            rows_read=self.rows_read,
            sources=self.sources,
            verified=self.verified,
        )

    # ------------------------------------------------------------------ queries

    def slices(
        self, n_units: Sequence[int] | None = None, state: str | int | None = None
    ) -> list[tuple[tuple, slice]]:
        """The ``(key, slice)`` of rows a query with these filters covers.

        Parameters
        ----------
        n_units : sequence of int, optional
            Numbers of units to keep (default all).
        state : None, "all-inverted", a bit string or an int
            ``None``: any state; ``"all-inverted"``: the state ``2^N - 1`` of each ``N``; a bit
            string (``"11110"``, unit 1 first) fixes ``N = len(state)``; an int needs a single
            ``N`` in ``n_units``.
        """
        wanted = self.n_values if n_units is None else tuple(int(n) for n in n_units)
        if isinstance(state, str) and state not in ("all-inverted", "all_inverted"):
            bits = state.strip()
            if not bits or set(bits) - {"0", "1"}:
                raise ValueError(
                    f"state = {state!r}: a bit string (unit 1 first) or 'all-inverted'"
                )
            if n_units is not None and len(bits) not in wanted:
                raise ValueError(
                    f"state = {state!r}: has {len(bits)} units, outside n_units = {list(wanted)}"
                )
            wanted, state = (len(bits),), int(bits, 2)
        elif isinstance(state, (int, np.integer)) and len(wanted) != 1:
            raise ValueError(f"state = {state!r}: an integer state needs a single n_units")
        out = []
        for n in wanted:
            if state is None:
                key = (n,)
            elif isinstance(state, str):
                key = (n, 2**n - 1)
            else:
                key = (n, int(state))
            if key in self._slices:
                out.append((key, self._slices[key]))
        return out

    def query(
        self,
        target: ArrayLike,
        k: int = 10,
        *,
        n_units: Sequence[int] | None = None,
        state: str | int | None = None,
        mask: NDArray[np.bool_] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The ``k`` indexed rows nearest to ``target``, nearest first.

        Parameters
        ----------
        target : array_like of shape (d,)
            One value per column, in the columns' units.
        k : int
        n_units, state
            Filters (see :meth:`slices`).
        mask : ndarray of bool, shape (n,), optional
            Rows allowed (e.g. from a ``where`` expression); applied exactly.

        Returns
        -------
        distance : ndarray of shape (m,)
            Scaled Euclidean distances, ``m <= k`` (fewer rows match than ``k``).
        rows : ndarray of int64, shape (m,)
            Positions in this index's arrays.
        """
        target = np.asarray(target, dtype=float).reshape(-1)
        if target.shape != (len(self.columns),):
            raise ValueError(
                f"target = {target.tolist()!r}: need {len(self.columns)} values, one per column "
                f"({', '.join(self.columns)})"
            )
        if not np.all(np.isfinite(target)):
            raise ValueError(f"target = {target.tolist()!r}: must be finite")
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
            raise ValueError(f"k = {k!r}: must be an integer >= 1")
        if mask is not None and mask.shape != (len(self),):
            raise ValueError(f"mask: need shape ({len(self)},), got {mask.shape}")
        point = target / self.scales
        far = np.flatnonzero(np.abs(point) > MAX_SCALED_TARGET)
        if far.size:
            j = int(far[0])
            raise ValueError(
                f"target {self.columns[j]} = {target[j]:g}: more than {MAX_SCALED_TARGET:g} "
                f"times the column's scale ({self.scales[j]:g}) from zero, farther from every "
                "row than a distance can be computed; give a target in the dataset's range"
            )
        found_d, found_i = [], []
        for key, part in self.slices(n_units, state):
            d, i = self._query_slice(key, part, point, int(k), mask)
            found_d.append(d)
            found_i.append(i)
        if not found_d:
            return np.empty(0), np.empty(0, dtype=np.int64)
        distance = np.concatenate(found_d)
        rows = np.concatenate(found_i)
        order = np.argsort(distance, kind="stable")[:k]
        return distance[order], rows[order]

    def _query_slice(self, key, part: slice, point, k: int, mask):
        size = part.stop - part.start
        if mask is None:
            d, i = self._tree(key).query(point, k=min(k, size))
            return np.atleast_1d(d), np.atleast_1d(i).astype(np.int64) + part.start
        allowed = mask[part]
        count = int(np.count_nonzero(allowed))
        if count == 0:
            return np.empty(0), np.empty(0, dtype=np.int64)
        if count <= _SCAN_ROWS or count * 16 < size:
            rows = np.flatnonzero(allowed) + part.start
            return _scan(self._scaled[rows], point, k, rows)
        # Ask for enough neighbours that k of them likely pass, and more until they do: the
        # first k allowed rows among the nearest k' are the k nearest allowed rows.
        want = min(size, max(2 * k, int(np.ceil(2.0 * k * size / count))))
        while True:
            d, i = self._tree(key).query(point, k=want)
            d, i = np.atleast_1d(d), np.atleast_1d(i)
            keep = allowed[i]
            if np.count_nonzero(keep) >= k or want >= size:
                return d[keep][:k], i[keep][:k].astype(np.int64) + part.start
            want = min(size, 4 * want)

    def scan(
        self,
        target: ArrayLike,
        k: int = 10,
        *,
        n_units: Sequence[int] | None = None,
        state: str | int | None = None,
        mask: NDArray[np.bool_] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """:meth:`query` by a brute-force scan of every row (the baseline and the oracle)."""
        point = np.asarray(target, dtype=float).reshape(-1) / self.scales
        keep = np.zeros(len(self), dtype=bool)
        for _, part in self.slices(n_units, state):
            keep[part] = True
        if mask is not None:
            keep &= mask
        rows = np.flatnonzero(keep)
        return _scan(self._scaled[rows], point, k, rows)


def _scan(scaled: NDArray, point: NDArray, k: int, rows: NDArray):
    distance = np.sqrt(np.sum((scaled - point) ** 2, axis=1))
    if distance.size > k:
        pick = np.argpartition(distance, k - 1)[:k]
    else:
        pick = np.arange(distance.size)
    pick = pick[np.argsort(distance[pick], kind="stable")]
    return distance[pick], rows[pick].astype(np.int64)


# ----------------------------------------------------------------------------- build


def build_index(
    root: str | Path,
    columns: Sequence[str] = DEFAULT_COLUMNS,
    scales: ArrayLike | None = None,
    *,
    info: DatasetInfo | None = None,
    verify: bool = True,
) -> LookupIndex:
    """Read ``columns`` (and the row identity) of every committed chunk and index them.

    Only ``ok`` rows with finite values in every column are indexed. With ``verify`` (the
    default, as every dataset read) each chunk's bytes are checked against the manifest's
    SHA-256 before they are decoded, which reads every file whole; ``verify=False`` reads only
    the needed columns and gives an index with ``verified = False``, which is never saved.

    Raises
    ------
    StoreError
        ``root`` is not a sweep directory, or (``verify``) a chunk changed after it was
        committed.
    ValueError
        An unknown or non-numeric column, or bad scales.
    """
    root = Path(root)
    info = info or dataset_info(root)
    columns = check_columns(root, columns)
    scales = check_scales(scales, columns)
    schema = read_schema(root)
    wanted = [*_ROW_COLUMNS, *columns]
    parts: dict[str, list[NDArray]] = {name: [] for name in (*wanted, "file", "row")}
    rows_read = 0
    for f, rel in enumerate(info.chunks):
        table = pq.read_table(info.open_chunk(rel, verify=verify), columns=wanted, schema=schema)
        values = {name: _numpy(table.column(name)) for name in wanted}
        n = table.num_rows
        rows_read += n
        keep = values["status"] == st.OK
        for name in columns:
            keep &= np.isfinite(values[name])
        for name in wanted:
            parts[name].append(values[name][keep])
        parts["file"].append(np.full(int(keep.sum()), f, dtype=np.int32))
        parts["row"].append(np.flatnonzero(keep).astype(np.int32))

    def joined(name, dtype):
        return np.concatenate(parts[name]).astype(dtype) if parts[name] else np.empty(0, dtype)

    n_units = joined("n_units", np.int8)
    requested = joined("requested", np.int64)
    design_id = joined("design_id", np.int64)
    order = np.lexsort((design_id, requested, n_units))
    points = (
        np.stack([joined(name, np.float64) for name in columns], axis=1)
        if parts["file"]
        else np.empty((0, len(columns)))
    )
    return LookupIndex(
        root=root,
        columns=columns,
        scales=scales,
        points=np.ascontiguousarray(points[order]),
        design_id=design_id[order],
        requested=requested[order],
        n_units=n_units[order],
        file=joined("file", np.int32)[order],
        row=joined("row", np.int32)[order],
        files=info.chunks,
        checksum=info.checksum,
        complete=info.complete,
        rows_read=rows_read,
        # The records the reads were checked against (``info``'s, not a later manifest's).
        sources=tuple(ChunkSource(r.path, r.sha256, int(r.bytes)) for r in info.records),
        verified=bool(verify),
    )


def _numpy(column: pa.ChunkedArray) -> NDArray:
    """Column as NumPy: nulls become NaN (floats) or -1 (integers)."""
    if pa.types.is_floating(column.type):
        return column.to_numpy().astype(np.float64, copy=False)
    return column.fill_null(-1).to_numpy()


def mask_of(index: LookupIndex, keys: Mapping[str, NDArray]) -> NDArray[np.bool_]:
    """Rows of ``index`` whose ``(design_id, requested)`` is among ``keys``' rows."""
    wanted = _row_key(np.asarray(keys["design_id"]), np.asarray(keys["requested"]))
    return np.isin(_row_key(index.design_id, index.requested), wanted)


def _row_key(design_id: NDArray, requested: NDArray) -> NDArray[np.int64]:
    # A state has at most 12 bits: one int64 holds both.
    return design_id.astype(np.int64) << 13 | (requested.astype(np.int64) & 0x1FFF)
