"""Parquet storage of sweep results: atomic chunk commits, manifest, verified readers.

The dataset schema (columns, units, metadata) lives in :mod:`dpfexplore.sweep.storage.schema` and is
re-exported here; the commit of a chunk file (atomic write, checksum, verified read) is the one
every chunked directory shares (:mod:`dpfexplore.io.commits`).

Layout of a sweep directory::

    results/paper-design-space/
        _manifest.json          committed chunks (row counts, sizes, SHA-256), job, versions
        _common_metadata        the dataset's Arrow schema and metadata (Parquet convention)
        N02/part-000000.parquet one chunk: designs [start, stop) of the plan for N = 2
        N02/part-000001.parquet
        N03/...

* One row per design-state, partitioned by number of units (one directory per ``N``; every
  file also holds the ``n_units`` column, so a chunk file is self-describing). The directory
  names are not ``key=value`` (Hive) names on purpose: Hive partitioning would hand ``n_units``
  back to pandas as a categorical that conflicts with the column in the files, whereas
  ``pandas.read_parquet(DIR)`` of this layout reads plain ``int8``. Readers that want to prune
  by ``N`` get it from each file's row-group statistics (min = max = N) or from the manifest.
* The schema is fixed before the first design is evaluated (:func:`dataset_schema`); every
  field carries its physical unit and a description in its Arrow field metadata
  (``unit``, ``description``), and the schema metadata key ``dpfexplore`` holds the job
  spec, seed, fingerprint, model version and package versions (:mod:`.schema`).
* A chunk is written to a unique temporary name (a leading ``.``, which Parquet readers skip),
  flushed and fsync-ed, then renamed onto its deterministic name ``N05/part-000012.parquet``:
  a retried chunk overwrites, it never duplicates, and a reader never sees half a file.
* ``_manifest.json`` is rewritten (atomically, by rename) *after* each chunk file is in place.
  It is the commit record: a chunk file the manifest does not list (a crash between rename
  and manifest write) does not exist for readers or for ``--resume``, which recomputes it.
  Use :func:`read_results` / :func:`open_dataset`, which read only manifest-listed files;
  ``pandas.read_parquet(DIR)`` reads every ``part-*.parquet`` and agrees with them once a
  sweep is complete.
* Reads are verified: :func:`read_results` / :func:`iter_results` read each chunk's bytes
  once, check their size and SHA-256 against the manifest, and decode the columns from those
  same bytes, so a chunk changed after it was committed (even in place, at the same size) is
  an error naming the chunk, never silently different numbers. The cost is reading every
  chunk file whole and one SHA-256 pass over it, whatever the columns asked for: SHA-256 runs
  at about 0.45 GB/s on the 2-core benchmark machine, so a 7.9 MB dataset of 89,600 rows
  (24 chunks) reads in about 410 ms instead of 390 ms with every column (+5 %) and in about
  107 ms instead of 90 ms with two columns (+20 %). ``verify=False`` (``dpfexplore query
  --no-verify``) skips it and reads only the columns asked for.
* Each chunk file also carries, in its Parquet key-value metadata, which chunk it is (``N``,
  index, designs ``[start, stop)``) and a SHA-256 of its decoded contents
  (:func:`table_digest`), so that a directory whose manifest is lost can be rebuilt from the
  chunk files that are provably intact (:mod:`dpfexplore.sweep.repair`).
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.dataset as pads
import pyarrow.parquet as pq

from ...io.commits import (
    MANIFEST,
    StoreError,
    commit_file,
    read_file_buffer,
    verified_bytes,
    verify_file,
)
from ...io.commits import remove_leftovers as _remove_leftovers
from ...io.files import BoundedReadError, atomic_write, check_file, file_sha256, read_bounded
from .row_filter import parse_filter
from .schema import (  # the store's public names include the schema's
    FORMAT,
    METADATA_KEY,
    STATUS_LABELS,
    STATUS_TYPE,
    column,
    dataset_metadata,
    describe_schema,
    design_fields,
    schema_metadata,
    table_from_columns,
    with_dataset_metadata,
)

__all__ = [
    "FORMAT",
    "MANIFEST",
    "METADATA_KEY",
    "STATUS_LABELS",
    "STATUS_TYPE",
    "ChunkRecord",
    "Manifest",
    "StoreError",
    "chunk_bytes",
    "chunk_identity",
    "chunk_path",
    "column",
    "dataset_metadata",
    "describe_schema",
    "design_fields",
    "file_sha256",
    "open_dataset",
    "read_file_buffer",
    "read_manifest",
    "read_results",
    "remove_leftovers",
    "schema_metadata",
    "table_digest",
    "table_from_columns",
    "verify_chunk",
    "with_dataset_metadata",
    "write_chunk",
    "write_manifest",
]

COMMON_METADATA = "_common_metadata"
#: Schema-metadata key, in each chunk file, of the chunk's identity and content digest.
CHUNK_KEY = b"dpfexplore.chunk"
_PART = re.compile(r"^N(\d+)/part-(\d+)\.parquet$")


# ----------------------------------------------------------------------------- chunks


@dataclass(frozen=True)
class ChunkRecord:
    """A committed chunk file.

    Attributes
    ----------
    path : str
        Relative POSIX path, ``N05/part-000012.parquet``.
    n_units, index : int
        Number of units and chunk number within its ``N``.
    start, stop : int
        Plan rows (designs) the chunk holds.
    rows : int
        Design-state rows in the file.
    bytes : int
        File size.
    sha256 : str
        Hex digest of the file's bytes.
    statuses : dict of str to int
        Rows per status label (for summaries without reading the data).
    """

    path: str
    n_units: int
    index: int
    start: int
    stop: int
    rows: int
    bytes: int
    sha256: str
    statuses: dict[str, int] = field(default_factory=dict)


def chunk_path(n_units: int, index: int) -> str:
    """Deterministic relative path of chunk ``index`` of the plan for ``n_units``."""
    return f"N{n_units:02d}/part-{index:06d}.parquet"


def _column_digest(digest, values: pa.ChunkedArray) -> None:
    array = values.combine_chunks() if values.num_chunks != 1 else values.chunk(0)
    if pa.types.is_dictionary(array.type):
        array = array.dictionary_decode()
    digest.update(np.asarray(array.is_valid()).tobytes())
    if pa.types.is_string(array.type) or pa.types.is_large_string(array.type):
        values = array.fill_null("").to_pylist()
        digest.update(np.asarray([len(v) for v in values], dtype=np.int64).tobytes())
        digest.update("".join(values).encode())
    elif pa.types.is_boolean(array.type):
        digest.update(np.asarray(array.fill_null(False)).tobytes())
    else:
        digest.update(np.asarray(array.fill_null(0)).tobytes())


def table_digest(table: pa.Table) -> str:
    """SHA-256 of a table's decoded contents: names, types, validity and values of every column.

    Independent of how the table is laid out in memory or encoded in a file (chunking,
    dictionary indices, compression), so the digest of a table read back from a chunk file
    equals the digest of the table that was written.
    """
    digest = hashlib.sha256()
    for name, values in zip(table.column_names, table.columns, strict=True):
        digest.update(f"{name}:{values.type}".encode())
        _column_digest(digest, values)
    return digest.hexdigest()


def chunk_identity(table: pa.Table) -> dict[str, Any] | None:
    """The identity a chunk file's table carries (:data:`CHUNK_KEY`), None if it has none."""
    raw = (table.schema.metadata or {}).get(CHUNK_KEY)
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except ValueError:
        return None


def write_chunk(
    root: str | Path, n_units: int, index: int, start: int, stop: int, table: pa.Table
) -> ChunkRecord:
    """Write one chunk file atomically and return its record (the manifest is not touched).

    Safe to run twice for the same chunk, even concurrently (a retried task): each writer has
    its own temporary file and the last rename wins; both wrote the same bytes. The file
    carries the chunk's identity and :func:`table_digest` in its key-value metadata.
    """
    relpath = chunk_path(n_units, index)
    identity = {
        "n_units": n_units,
        "index": index,
        "start": start,
        "stop": stop,
        "rows": table.num_rows,
        "content_sha256": table_digest(table),
    }
    metadata = dict(table.schema.metadata or {})
    metadata[CHUNK_KEY] = json.dumps(identity, sort_keys=True).encode()
    table = table.replace_schema_metadata(metadata)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink, compression="zstd")
    written = commit_file(root, relpath, memoryview(sink.getvalue()))
    return ChunkRecord(
        path=relpath,
        n_units=n_units,
        index=index,
        start=start,
        stop=stop,
        rows=table.num_rows,
        bytes=written.bytes,
        sha256=written.sha256,
    )


def unverified_chunk(path: str | Path) -> Path:
    """``path``, a chunk file to read unverified, once it is a regular file within its limit.

    Raises
    ------
    StoreError
        Naming the chunk if it is missing, not a regular file or larger than a chunk may be.
    """
    try:
        check_file(path, "chunk")
    except BoundedReadError as exc:
        raise StoreError(f"chunk {exc}") from None
    except FileNotFoundError:
        raise StoreError(f"chunk {path}: missing (it is in {MANIFEST})") from None
    return Path(path)


def chunk_bytes(root: str | Path, record: ChunkRecord, *, verify: bool = True) -> pa.Buffer:
    """The bytes of a committed chunk file, checked against its manifest record.

    Returned as an Arrow buffer (:func:`read_file_buffer`), ready for ``pa.BufferReader``.

    Raises
    ------
    StoreError
        Naming the chunk, if it is missing, or (``verify``) its size or SHA-256 differs from
        the record: it changed after it was committed.
    """
    return verified_bytes(
        root,
        record,
        verify=verify,
        remedy="recompute it with 'dpfexplore sweep JOB --out DIR --resume' (or read "
        "unverified with verify=False / --no-verify)",
    )


def verify_chunk(root: str | Path, record: ChunkRecord, *, checksum: bool = True) -> str | None:
    """Why a committed chunk cannot be trusted any more, or None if it is intact."""
    return verify_file(root, record, checksum=checksum)


def remove_leftovers(root: str | Path) -> list[Path]:
    """Delete temporary files of interrupted writes; returns what was removed.

    Call it only while no writer runs (before a sweep starts or after it ends).
    """
    return _remove_leftovers(root, ("N*",))


def part_files(root: str | Path) -> list[str]:
    """Relative paths of every chunk file present, committed or not."""
    root = Path(root)
    found = []
    for path in root.glob("N*/part-*.parquet"):
        rel = path.relative_to(root).as_posix()
        if _PART.match(rel):
            found.append(rel)
    return sorted(found)


# ----------------------------------------------------------------------------- manifest


@dataclass
class Manifest:
    """The commit record of a sweep directory (``_manifest.json``).

    Attributes
    ----------
    fingerprint : str
        :meth:`JobSpec.fingerprint` of the job that owns the directory.
    job : dict
        The job as :meth:`JobSpec.to_dict`.
    result_defining : dict
        :meth:`JobSpec.result_defining`, to name the first differing key on a refused resume.
    model_version : str
    versions : dict
        Package versions of the run that created the directory.
    plan : dict of int to int
        Designs per ``N``.
    chunk_sizes : dict of int to int
        Designs per chunk for each ``N`` (fixed when the directory is created).
    chunks : dict of str to ChunkRecord
        Committed chunks by relative path.
    complete : bool
        Every chunk of the plan is committed.
    """

    fingerprint: str
    job: dict[str, Any]
    result_defining: dict[str, Any]
    model_version: str
    versions: dict[str, str]
    plan: dict[int, int]
    chunk_sizes: dict[int, int]
    chunks: dict[str, ChunkRecord] = field(default_factory=dict)
    complete: bool = False
    format: str = FORMAT
    created: str = ""
    updated: str = ""

    @property
    def n_rows(self) -> int:
        """Committed design-state rows."""
        return sum(record.rows for record in self.chunks.values())

    @property
    def n_designs_committed(self) -> int:
        """Committed designs."""
        return sum(record.stop - record.start for record in self.chunks.values())

    def to_json(self) -> str:
        """Canonical JSON text."""
        data = asdict(self)
        data["plan"] = {str(k): v for k, v in self.plan.items()}
        data["chunk_sizes"] = {str(k): v for k, v in self.chunk_sizes.items()}
        data["chunks"] = {k: asdict(v) for k, v in sorted(self.chunks.items())}
        return json.dumps(data, indent=1, sort_keys=True) + "\n"

    @classmethod
    def from_json(cls, text: str) -> Manifest:
        """Parse :meth:`to_json` output."""
        data = json.loads(text)
        data["plan"] = {int(k): int(v) for k, v in data["plan"].items()}
        data["chunk_sizes"] = {int(k): int(v) for k, v in data["chunk_sizes"].items()}
        data["chunks"] = {k: ChunkRecord(**v) for k, v in data["chunks"].items()}
        return cls(**data)


def write_manifest(root: str | Path, manifest: Manifest) -> None:
    """Replace ``_manifest.json`` atomically (the commit point of every chunk it lists)."""
    now = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    if not manifest.created:
        manifest.created = now
    manifest.updated = now
    atomic_write(Path(root) / MANIFEST, manifest.to_json().encode())


def read_manifest(root: str | Path) -> Manifest:
    """The manifest of a sweep directory.

    Raises
    ------
    StoreError
        If the directory has no manifest or an unreadable one.
    """
    path = Path(root) / MANIFEST
    try:
        text = read_bounded(path, "manifest").decode("utf-8")
    except (BoundedReadError, UnicodeDecodeError) as exc:
        raise StoreError(f"{path}: unreadable manifest ({exc})") from None
    except FileNotFoundError:
        if not Path(root).is_dir():
            raise StoreError(f"{root}: no such directory") from None
        hint = ""
        if part_files(root):
            hint = (
                "; it holds chunk files: if its manifest was deleted, rebuild it with "
                "'dpfexplore sweep JOB --out DIR --repair'"
            )
        raise StoreError(f"{root}: not a sweep directory (no {MANIFEST}){hint}") from None
    try:
        manifest = Manifest.from_json(text)
    except (ValueError, KeyError, TypeError, RecursionError) as exc:
        raise StoreError(f"{path}: unreadable manifest ({exc})") from None
    if manifest.format != FORMAT:
        raise StoreError(f"{path}: format {manifest.format!r}, this dpfexplore reads {FORMAT!r}")
    return manifest


def write_common_metadata(root: str | Path, schema: pa.Schema) -> None:
    """Write the dataset schema to ``_common_metadata`` (atomically)."""
    sink = pa.BufferOutputStream()
    pq.write_metadata(schema, sink)
    atomic_write(Path(root) / COMMON_METADATA, memoryview(sink.getvalue()))


def read_schema(root: str | Path) -> pa.Schema:
    """The dataset schema (with field and dataset metadata) of a sweep directory."""
    path = Path(root) / COMMON_METADATA
    try:
        check_file(path, "dataset metadata")
        return pq.read_schema(path)
    except BoundedReadError as exc:
        raise StoreError(str(exc)) from None
    except FileNotFoundError:
        if not Path(root).is_dir():
            raise StoreError(f"{root}: no such directory") from None
        raise StoreError(f"{root}: not a sweep directory (no {COMMON_METADATA})") from None


# ----------------------------------------------------------------------------- readers


def committed_files(root: str | Path, manifest: Manifest | None = None) -> list[Path]:
    """Manifest-listed chunk files, in (N, chunk) order."""
    root = Path(root)
    manifest = manifest or read_manifest(root)
    records = sorted(manifest.chunks.values(), key=lambda r: (r.n_units, r.index))
    return [root / record.path for record in records]


def _existing_directory(root: Path) -> None:
    if not root.exists():
        raise StoreError(f"{root}: no such directory")
    if not root.is_dir():
        raise StoreError(f"{root}: not a directory (a sweep dataset is a directory)")


def open_dataset(root: str | Path, *, verify: bool = True) -> pads.Dataset:
    """A :mod:`pyarrow.dataset` over the committed chunks only, with the dataset schema.

    ``verify`` checks every committed file's SHA-256 against the manifest first (one pass over
    all the files, see the module docstring); the dataset then reads them from disk again, so
    this guards against damage done before the call, not during it.
    """
    root = Path(root)
    _existing_directory(root)
    manifest = read_manifest(root)
    if verify:
        for record in manifest.chunks.values():
            problem = verify_chunk(root, record)
            if problem is not None:
                raise StoreError(
                    f"chunk {root / record.path}: {problem}: the file changed after it was "
                    "committed; recompute it with --resume (or open with verify=False)"
                )
    files = [str(p) for p in committed_files(root, manifest)]
    return pads.dataset(files, schema=read_schema(root), format="parquet")


def iter_results(
    root: str | Path,
    *,
    columns: Sequence[str] | None = None,
    where: str | None = None,
    verify: bool = True,
) -> Iterator[pd.DataFrame]:
    """Committed rows chunk by chunk, those for which the filter ``where`` is true.

    ``where`` is a condition over the columns (``"n_units == 5 and stiffness > 0.05"``), parsed
    and checked by :func:`~dpfexplore.sweep.storage.row_filter.parse_filter` before any row is read
    and evaluated by Arrow on the columns: it is never run as Python code.

    Memory stays bounded by one chunk (plus what the caller keeps). With ``verify`` (the
    default) each chunk's bytes are checked against the manifest's size and SHA-256 before
    any of its rows is returned (cost: module docstring).

    Raises
    ------
    StoreError
        For a missing directory, a directory that is not a sweep, or (``verify``) a chunk that
        changed after it was committed, naming the chunk.
    KeyError
        For a column that is not in the dataset.
    FilterError
        (a ValueError) For a ``where`` that is not an allowed condition over these columns.
    """
    root = Path(root)
    _existing_directory(root)
    schema = read_schema(root)
    names = schema.names
    wanted = list(columns) if columns else list(names)
    unknown = [c for c in wanted if c not in names]
    if unknown:
        raise KeyError(f"unknown column {unknown[0]!r}; columns: {', '.join(names)}")
    row_filter = parse_filter(where, schema) if where else None
    needed = list(dict.fromkeys([*wanted, *(row_filter.columns if row_filter else ())]))
    manifest = read_manifest(root)
    for record in sorted(manifest.chunks.values(), key=lambda r: (r.n_units, r.index)):
        if verify:  # decode from the very bytes that were checked
            source = pa.BufferReader(chunk_bytes(root, record))
        else:
            source = unverified_chunk(root / record.path)
        table = pq.read_table(source, columns=needed, schema=schema)
        if row_filter is not None:
            table = row_filter.apply(table)
        yield table.select(wanted).to_pandas()


def read_results(
    root: str | Path,
    *,
    columns: Sequence[str] | None = None,
    where: str | None = None,
    verify: bool = True,
) -> pd.DataFrame:
    """Committed rows of a sweep directory as one DataFrame (see :func:`iter_results`).

    Every chunk read is verified against the manifest's SHA-256 unless ``verify=False``
    (cost: one hashing pass over the chunk files, module docstring).
    """
    frames = list(iter_results(root, columns=columns, where=where, verify=verify))
    non_empty = [f for f in frames if len(f)]
    if non_empty:
        return pd.concat(non_empty, ignore_index=True)
    if frames:
        return frames[0].reset_index(drop=True)
    empty = read_schema(root).empty_table().to_pandas()
    return empty[list(columns)] if columns else empty
