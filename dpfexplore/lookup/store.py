"""The lookup index kept beside its dataset: saved, verified on load, rebuilt when it must be.

An index of ``columns`` of the dataset ``DIR`` is saved as ``DIR/_lookup-<col>+<col>.npz``
(:func:`index_path`): NumPy arrays and one JSON string, read with ``allow_pickle=False``; the
leading ``_`` keeps Parquet readers from taking it for data, so ``pandas.read_parquet(DIR)`` and
``dpfexplore sweep --resume`` are unaffected. It is written to a temporary name and renamed into
place, so a reader never sees half a file and two writers of the same index cannot mix.

What the file records (format :data:`INDEX_FORMAT`)
    * ``arrays_sha256``: SHA-256 over every array's name, dtype, shape and bytes, in the fixed
      order of :data:`ARRAYS` (:func:`arrays_checksum`);
    * ``chunks``: for each chunk the rows were read from, its path (relative, inside the
      dataset) and its SHA-256 and size as the manifest listed them *when the chunk was read
      and checked against them*;
    * the dataset checksum (:func:`~dpfexplore.sweep.storage.datasets.dataset_checksum`) at build
      time.

Only an index built from verified reads is saved: one built with ``verify=False`` (``lookup
--no-verify``) serves its run from memory and is never written, so a damaged chunk read
unverified cannot leave an index that outlives the repair of the chunk.

What :func:`load_index` checks, all before a row is used
    the format and the columns; every array present with its dtype and a consistent shape
    (``points`` ``n x len(columns)``, every other array ``n``); ``arrays_sha256``; values in
    range (chunk numbers, rows within their chunk, numbers of units, states, finite points,
    rows in index order); every chunk path inside the dataset; every chunk record equal to the
    dataset's current manifest record (path, SHA-256, size) and the dataset checksum equal to the
    recorded one. Any exception while reading the file (a truncated or bit-flipped zip, a
    missing member, JSON garbage, ...) is an :class:`UnreadableIndexError`; contents that read
    but fail a check are an :class:`InvalidIndexError`; a dataset that changed is a
    :class:`~.index.StaleIndexError` (the base class of both). :func:`open_index` rebuilds the
    index from the verified dataset in every one of these cases, saves the new file and says why
    in :attr:`IndexOrigin.reason` (e.g. "its arrays do not match their checksum").

    ``arrays_sha256`` catches damage and hand edits; it is not a signature: whoever can write
    the file can recompute it. What such a file can still change is *which* rows become
    candidates, never what is reported: :func:`~.query.lookup` re-reads each candidate's row
    from the verified chunk (its identity must match the index's) and re-solves its design.

Cost of the load checks, measured with ``time.perf_counter`` (median of 5 runs, 3 repeats, on
the 2-core benchmark machine, an AMD EPYC; a synthetic index of 1,000,000 rows over ``tip_x,
tip_y`` in 100 chunks, a 41 MB file): **about 45 ms per million indexed rows** for every check
above (the SHA-256 of the arrays about 23 ms of it, the shape, range and order checks the
rest), on top of about 20 ms to read the arrays from the file (page cache); loading the whole
index, trees included, 0.40 s.

The trees are not saved - :class:`scipy.spatial.cKDTree` has no serialised form short of
pickle - but rebuilt on load: 0.2-0.3 s for the 650,000 indexed rows of a million-row dataset,
against about 1.8 s to read the columns from Parquet again.
"""

from __future__ import annotations

import hashlib
import json
import logging
import re
import time
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..io.files import atomic_writer, check_file
from ..model.domain import MAX_UNITS
from ..sweep.storage.datasets import DatasetInfo, dataset_info
from .index import (
    DEFAULT_COLUMNS,
    ChunkSource,
    LookupIndex,
    StaleIndexError,
    build_index,
    check_columns,
    check_scales,
    stale_reason,
)

__all__ = [
    "ARRAYS",
    "INDEX_FORMAT",
    "IndexOrigin",
    "InvalidIndexError",
    "UnreadableIndexError",
    "arrays_checksum",
    "index_path",
    "load_index",
    "open_index",
    "save_index",
]

logger = logging.getLogger(__name__)

#: Identifies the file layout of a saved index; bump when it changes incompatibly.
INDEX_FORMAT = "dpfexplore-lookup-index/2"

#: The arrays of a saved index, in checksum order: file member, LookupIndex attribute, dtype
#: (little-endian, exactly), number of dimensions.
ARRAYS: tuple[tuple[str, str, np.dtype, int], ...] = (
    ("points", "points", np.dtype("<f8"), 2),
    ("design_id", "design_id", np.dtype("<i8"), 1),
    ("requested", "requested", np.dtype("<i8"), 1),
    ("n_units", "n_units", np.dtype("i1"), 1),
    ("chunk_file", "file", np.dtype("<i4"), 1),
    ("chunk_row", "row", np.dtype("<i4"), 1),
)

_SHA256 = re.compile(r"[0-9a-f]{64}")


class UnreadableIndexError(StaleIndexError):
    """The index file cannot be read (not a zip, truncated, damaged, a member missing, ...)."""


class InvalidIndexError(StaleIndexError):
    """The index file reads, but its contents fail a check (format, shapes, checksum, paths)."""


def index_path(root: str | Path, columns: Sequence[str]) -> Path:
    """Where the index of ``columns`` of the dataset ``root`` is saved."""
    return Path(root) / f"_lookup-{'+'.join(columns)}.npz"


def arrays_checksum(arrays: Mapping[str, NDArray]) -> str:
    """SHA-256 (hex) of the arrays of :data:`ARRAYS`: each one's name, dtype, shape and bytes.

    Parameters
    ----------
    arrays : mapping of str to ndarray
        Keyed by file member name (``"points"``, ``"design_id"``, ...).
    """
    digest = hashlib.sha256()
    for name, _, _, _ in ARRAYS:
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}:{array.dtype.str}:{array.shape}\n".encode())
        digest.update(array.reshape(-1).view(np.uint8))
    return digest.hexdigest()


def save_index(index: LookupIndex, path: str | Path | None = None) -> Path:
    """Write ``index`` atomically (``.npz``, no pickle); returns the path.

    Raises
    ------
    ValueError
        The index was not built from verified reads (``verified`` is False): it is not saved.
    """
    if not index.verified or len(index.sources) != len(index.files):
        raise ValueError(
            f"{index.root}: this lookup index was not built from verified chunk reads; it is "
            "not saved (build it with verify=True)"
        )
    path = Path(path) if path is not None else index_path(index.root, index.columns)
    arrays = {name: getattr(index, attr) for name, attr, _, _ in ARRAYS}
    meta = {
        "format": INDEX_FORMAT,
        "columns": list(index.columns),
        "chunks": [
            {"path": s.path, "sha256": s.sha256, "bytes": int(s.bytes)} for s in index.sources
        ],
        "checksum": index.checksum,
        "complete": bool(index.complete),
        "rows_read": int(index.rows_read),
        "arrays_sha256": arrays_checksum(arrays),
    }
    with atomic_writer(path) as fh:
        np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
    return path


# ----------------------------------------------------------------------------- load checks


def _read_file(path: Path) -> tuple[Any, dict[str, NDArray]]:
    """The meta JSON and the arrays of an index file, or UnreadableIndexError."""
    try:
        check_file(path, "lookup index")  # a ValueError: rebuilt like any unreadable index
        with np.load(path, allow_pickle=False) as data:
            names = set(data.files)
            missing = [n for n in ("meta", *(a[0] for a in ARRAYS)) if n not in names]
            if missing:
                raise KeyError(f"no member {missing[0]!r}")
            meta_array = data["meta"]
            if meta_array.shape != () or meta_array.dtype.kind != "U":
                raise ValueError(f"meta is a {meta_array.dtype} array of shape {meta_array.shape}")
            meta = json.loads(str(meta_array))
            arrays = {name: np.asarray(data[name]) for name, _, _, _ in ARRAYS}
    except FileNotFoundError:
        raise
    # A cache file may hold any bytes: what np.load, zipfile and zlib raise for them (a bad
    # zip or member, a truncated or corrupt stream, an unsupported compression method, a
    # header claiming an array too large to allocate) and what the checks above raise all
    # mean the same thing: rebuild it.
    except (
        OSError,
        EOFError,
        ValueError,
        KeyError,
        NotImplementedError,
        MemoryError,
        zipfile.BadZipFile,
        zlib.error,
    ) as exc:
        reason = f"it is unreadable ({type(exc).__name__}: {_one_line(exc)})"
        raise UnreadableIndexError(f"{path}: lookup index rejected: {reason}", reason) from exc
    return meta, arrays


def _one_line(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else ""
    return text[:120]


def _invalid(path: Path, reason: str) -> InvalidIndexError:
    return InvalidIndexError(f"{path}: lookup index rejected: {reason}; rebuild it", reason)


def _check_meta(meta: Any, path: Path, columns: Sequence[str]) -> list[ChunkSource]:
    """The chunk records of a valid meta mapping, else InvalidIndexError naming the problem."""
    if not isinstance(meta, dict):
        raise _invalid(path, f"its metadata is not a mapping (a JSON {type(meta).__name__})")
    if meta.get("format") != INDEX_FORMAT:
        raise _invalid(
            path, f"it is of format {str(meta.get('format'))[:60]!r}, need {INDEX_FORMAT!r}"
        )
    if meta.get("columns") != list(columns):
        raise _invalid(path, f"it indexes {str(meta.get('columns'))[:80]}, need {list(columns)}")
    kinds = {
        "chunks": list,
        "checksum": str,
        "complete": bool,
        "rows_read": int,
        "arrays_sha256": str,
    }
    for key, kind in kinds.items():
        value = meta.get(key)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise _invalid(path, f"its metadata {key!r} is missing or not a {kind.__name__}")
    if meta["rows_read"] < 0:
        raise _invalid(path, "its metadata 'rows_read' is negative")
    sources = []
    for record in meta["chunks"]:
        ok = (
            isinstance(record, dict)
            and set(record) == {"path", "sha256", "bytes"}
            and isinstance(record["path"], str)
            and isinstance(record["sha256"], str)
            and _SHA256.fullmatch(record["sha256"]) is not None
            and isinstance(record["bytes"], int)
            and not isinstance(record["bytes"], bool)
        )
        if not ok:
            raise _invalid(path, "its metadata holds a malformed chunk record")
        sources.append(ChunkSource(record["path"], record["sha256"], record["bytes"]))
    return sources


def _inside(rel: str) -> bool:
    """Whether ``rel`` is a plain relative POSIX path that stays inside the dataset directory.

    Judged on the text alone: a dataset whose ``N05`` directory is a symlink to another disk
    is still one dataset (the path must also be a committed chunk's, checked next).
    """
    pure = PurePosixPath(rel)
    return not (
        not rel
        or "\\" in rel
        or "\x00" in rel
        or pure.is_absolute()
        or ".." in pure.parts
        or rel.startswith("~")
    )


def _check_arrays(
    arrays: Mapping[str, NDArray],
    meta: Mapping[str, Any],
    sources: Sequence[ChunkSource],
    rows_of: Mapping[str, int],
    columns: Sequence[str],
    path: Path,
) -> None:
    """InvalidIndexError unless the arrays have their dtypes, shapes, checksum and ranges."""
    n = None
    for name, _, dtype, ndim in ARRAYS:
        array = arrays[name]
        if array.dtype != dtype or array.ndim != ndim:
            raise _invalid(
                path,
                f"its array {name!r} is {array.dtype} with {array.ndim} dimensions, need "
                f"{dtype} with {ndim}",
            )
        n = array.shape[0] if n is None else n
        want = (n, len(columns)) if name == "points" else (n,)
        if array.shape != want:
            raise _invalid(path, f"its array {name!r} has shape {array.shape}, need {want}")
    if arrays_checksum(arrays) != meta["arrays_sha256"]:
        raise _invalid(path, "its arrays do not match their checksum")
    if not n:
        return
    # Ranges: a consistent-looking file with an edited checksum must still not index outside
    # its chunks or break the slices the trees are built on.
    file, row = arrays["chunk_file"], arrays["chunk_row"]
    n_units, requested = arrays["n_units"].astype(np.int64), arrays["requested"]
    if file.min() < 0 or file.max() >= len(sources):
        raise _invalid(path, "it has rows of a chunk it does not list")
    limit = np.array([rows_of.get(s.path, 0) for s in sources], dtype=np.int64)
    if row.min() < 0 or np.any(row >= limit[file]):
        raise _invalid(path, "it has rows beyond the end of their chunk")
    if n_units.min() < 1 or n_units.max() > MAX_UNITS:
        raise _invalid(path, f"it has numbers of units outside 1..{MAX_UNITS}")
    if requested.min() < 0 or np.any(requested >= (np.int64(1) << n_units)):
        raise _invalid(path, "it has states outside 0..2^N - 1")
    if not np.all(np.isfinite(arrays["points"])):
        raise _invalid(path, "it has non-finite points")
    # Rows sorted by (n_units, requested, design_id), each row once: the slices depend on it.
    d_n, d_r, d_i = np.diff(n_units), np.diff(requested), np.diff(arrays["design_id"])
    in_order = (d_n > 0) | ((d_n == 0) & ((d_r > 0) | ((d_r == 0) & (d_i > 0))))
    if not np.all(in_order):
        raise _invalid(path, "it has rows out of order or repeated")


def load_index(
    root: str | Path,
    columns: Sequence[str] = DEFAULT_COLUMNS,
    scales: ArrayLike | None = None,
    *,
    info: DatasetInfo | None = None,
    path: str | Path | None = None,
) -> LookupIndex:
    """Load the saved index of ``columns`` of a dataset, after checking all of it.

    The checks are listed in the module docstring.

    Raises
    ------
    FileNotFoundError
        No index of these columns is saved.
    UnreadableIndexError
        The file cannot be read (any exception while reading it).
    InvalidIndexError
        Its contents fail a check (format, columns, shapes, checksum, ranges, paths).
    StaleIndexError
        The dataset changed after the index was built (the base class of the two above).
    """
    root = Path(root)
    info = info or dataset_info(root)
    path = Path(path) if path is not None else index_path(root, columns)
    meta, arrays = _read_file(path)
    sources = _check_meta(meta, path, columns)
    outside = [s.path for s in sources if not _inside(s.path)]
    if outside:
        raise _invalid(path, f"it names a chunk outside the dataset ({outside[0][:80]!r})")
    stale = stale_reason([s.path for s in sources], sources, meta["checksum"], info)
    if stale is not None:
        raise StaleIndexError(f"{path}: lookup index rejected: {stale}; rebuild it", stale)
    rows_of = {r.path: int(r.rows) for r in info.records}
    _check_arrays(arrays, meta, sources, rows_of, columns, path)
    index = LookupIndex(
        root=root,
        columns=tuple(columns),
        scales=check_scales(scales, columns),
        **{attr: arrays[name] for name, attr, _, _ in ARRAYS},
        files=tuple(s.path for s in sources),
        checksum=meta["checksum"],
        complete=meta["complete"],
        rows_read=meta["rows_read"],
        sources=tuple(sources),
        verified=True,
    )
    index.check(info)
    return index


# ----------------------------------------------------------------------------- open


@dataclass(frozen=True)
class IndexOrigin:
    """How :func:`open_index` got its index.

    Attributes
    ----------
    action : {"loaded", "built", "rebuilt"}
        Loaded from its file; built (no file yet); rebuilt (the file was stale, unreadable or
        failed a check, or the caller discarded it).
    path : Path
        The index file.
    seconds : float
        Wall time of the load or build (trees included).
    saved : bool
        Whether a built index was written to ``path`` (False when the directory is read-only,
        or the index was built from unverified reads).
    reason : str or None
        One line: why it was rebuilt, and why it was not saved.
    verified : bool
        The index comes from chunk reads checked against the manifest's SHA-256.
    """

    action: str
    path: Path
    seconds: float
    saved: bool = False
    reason: str | None = None
    verified: bool = True


def open_index(
    root: str | Path,
    columns: Sequence[str] = DEFAULT_COLUMNS,
    scales: ArrayLike | None = None,
    *,
    rebuild: bool = True,
    save: bool = True,
    info: DatasetInfo | None = None,
    verify: bool = True,
    discard: str | None = None,
) -> tuple[LookupIndex, IndexOrigin]:
    """An index of ``columns``: loaded when its file passes every check, else built.

    Parameters
    ----------
    rebuild : bool
        Rebuild a stale, unreadable or invalid index (default); False raises instead.
    save : bool
        Save a built index beside the dataset (a read-only directory is logged, not an error).
        An index built with ``verify=False`` is never saved.
    verify : bool
        Check each chunk's SHA-256 when building (:func:`~.index.build_index`).
    discard : str, optional
        Do not load the saved file; rebuild, giving this as the reason (a caller found that the
        loaded index disagrees with the dataset).

    Raises
    ------
    StaleIndexError
        With ``rebuild=False``, when the saved index is stale, unreadable or invalid
        (:class:`UnreadableIndexError`, :class:`InvalidIndexError`), or ``discard`` is given.
    StoreError, ValueError
        As :func:`build_index`.
    """
    root = Path(root)
    info = info or dataset_info(root)
    columns = check_columns(root, columns)
    path = index_path(root, columns)
    start = time.perf_counter()
    rejected = None
    if discard is not None:
        if not rebuild:
            raise StaleIndexError(f"{path}: lookup index rejected: {discard}", discard)
        rejected = discard
    elif path.exists():
        try:
            index = load_index(root, columns, scales, info=info, path=path)
            return index, IndexOrigin("loaded", path, time.perf_counter() - start)
        except FileNotFoundError:  # removed since exists(): as if there were none
            pass
        except StaleIndexError as exc:  # stale, unreadable or invalid: it is a cache
            if not rebuild:
                raise
            rejected = exc.reason
    index = build_index(root, columns, scales, info=info, verify=verify)
    saved, unsaved = False, None
    if save and not index.verified:
        unsaved = (
            "not saved: built from chunks read without SHA-256 checks (--no-verify), it "
            "serves this run only"
        )
    elif save:
        try:
            save_index(index, path)
            saved = True
        except OSError as exc:
            unsaved = f"not saved: {exc}"
            logger.warning("lookup index of %s not saved: %s", root, exc)
    reason = "; ".join(r for r in (rejected, unsaved) if r) or None
    action = "built" if rejected is None else "rebuilt"
    return index, IndexOrigin(
        action, path, time.perf_counter() - start, saved, reason, verified=index.verified
    )
