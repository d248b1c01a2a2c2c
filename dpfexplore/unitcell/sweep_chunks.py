"""The chunks of a unit-cell sweep: what one computes, its files, their manifest, the merge.

A sweep directory (:func:`~.sweep.run_unitcell_sweep`)::

    DIR/.dpfexplore-lock            held while a sweep runs (one writer per directory)
    DIR/job.json                    the job's fingerprint and the job as read
    DIR/chunks/_manifest.json       the commit record: fingerprint, job, plan, and every
                                    committed chunk's files with their sizes and SHA-256
    DIR/chunks/part-00012.designs.parquet   one row per geometry of chunk 12
    DIR/chunks/part-00012.curves.parquet    every point of its traced paths (absent if none)
    DIR/curves.parquet, DIR/designs.parquet merged from the verified chunks
    DIR/manifest.json               written last: counts per status, the files

A chunk is committed as a finger sweep's is (:mod:`dpfexplore.io.commits`): its files are
written by a write-then-rename, then the manifest, rewritten atomically, lists them with their
sizes and SHA-256. A file the manifest does not list does not exist for the sweep; a listed
file that is missing, or whose size or checksum differs, is recomputed when the sweep resumes,
and the merge reads every file once, checked against its checksum.
"""

from __future__ import annotations

import logging
import math
import time
from collections import Counter
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, ClassVar

import pandas as pd
import pyarrow as pa

from ..io.commits import (
    MANIFEST,
    FileRecord,
    StoreError,
    commit_file,
    read_json,
    remove_leftovers,
    verified_bytes,
    verify_file,
    write_json,
)

__all__ = [
    "CHUNKS",
    "CellChunk",
    "CellTask",
    "ChunkManifest",
    "UnitCellWork",
    "chunk_problem",
    "merge_chunks",
    "parquet_bytes",
    "plan_problem",
    "plan_tasks",
    "read_manifest",
    "remove_uncommitted",
    "write_manifest",
]

logger = logging.getLogger(__name__)

#: The folder of a sweep directory that holds its chunk files and their manifest.
CHUNKS = "chunks"
#: Identifies the layout of ``chunks/_manifest.json``.
FORMAT = "dpfexplore-unitcell-chunks/1"
#: Columns of ``curves.parquet`` when no geometry was traced.
CURVE_COLUMNS = ("curve", "H", "t", "r_b", "E", "nu", "displacement", "energy", "force")


@dataclass(frozen=True)
class CellTask:
    """Geometries ``[start, stop)`` of a job, chunk number ``index``.

    Attributes
    ----------
    index, start, stop : int
    rows : tuple of (int, tuple of float)
        Each geometry's index in the job and its ``H, t, r_b`` (mm), ``E`` (MPa), ``nu``.
    """

    index: int
    start: int
    stop: int
    rows: tuple[tuple[int, tuple[float, ...]], ...] = field(repr=False)

    @property
    def path(self) -> str:
        """The chunk's name: its files are ``NAME.designs.parquet`` and ``NAME.curves.parquet``."""
        return f"part-{self.index:05d}"


def plan_tasks(geometries: Any, size: int) -> list[CellTask]:
    """The chunks of ``size`` geometries (the last one shorter) of an ``(n, 5)`` array."""
    indexed = tuple(enumerate(map(tuple, geometries.tolist())))
    return [
        CellTask(k, start, min(start + size, len(indexed)), indexed[start : start + size])
        for k, start in enumerate(range(0, len(indexed), size))
    ]


@dataclass(frozen=True)
class CellChunk:
    """A committed chunk: its geometries, its files, the count of its designs per status."""

    index: int
    start: int
    stop: int
    designs: FileRecord
    curves: FileRecord | None
    statuses: dict[str, int]

    @property
    def path(self) -> str:
        """The chunk's name (:attr:`CellTask.path`)."""
        return f"part-{self.index:05d}"

    @property
    def files(self) -> list[FileRecord]:
        """Its files: designs, then curves if any."""
        return [self.designs] if self.curves is None else [self.designs, self.curves]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "index": self.index,
            "start": self.start,
            "stop": self.stop,
            "designs": self.designs.to_dict(),
            "curves": None if self.curves is None else self.curves.to_dict(),
            "statuses": dict(sorted(self.statuses.items())),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CellChunk:
        """Parse :meth:`to_dict` output."""
        curves = data["curves"]
        return cls(
            index=int(data["index"]),
            start=int(data["start"]),
            stop=int(data["stop"]),
            designs=FileRecord(**data["designs"]),
            curves=None if curves is None else FileRecord(**curves),
            statuses={str(k): int(v) for k, v in data["statuses"].items()},
        )


def _trace_chunk(rows, options: dict) -> tuple[list, list]:
    """Trace every geometry of a chunk: frames of curves, rows of designs."""
    from .shell import unit_cell_curve

    frames, designs = [], []
    for index, (H, t, r_b, E, nu) in rows:
        record = {"design": index, "H": H, "t": t, "r_b": r_b, "E": E, "nu": nu}
        try:
            run = unit_cell_curve(
                H,
                t,
                r_b,
                E,
                nu,
                travel=options["travel"] * H,
                n_elements=options["n_elements"],
                max_steps=options["max_steps"],
            )
        except ValueError as exc:
            designs.append({**record, "status": "invalid", "message": str(exc)})
            continue
        except ArithmeticError as exc:  # a numerical failure of this geometry is its row only
            designs.append({**record, "status": "error", "message": f"{type(exc).__name__}: {exc}"})
            continue
        row = {
            **record,
            "status": run.status,
            "message": run.message,
            "steps": run.n_steps,
            "seconds": run.elapsed,
            "initial_stiffness": run.initial_stiffness,
            "first_fold": float(run.folds[0]) if run.folds.size else math.nan,
            "tip_dis": math.nan if run.tip_dis is None else run.tip_dis,
            "tip_kind": run.tip_kind or "",
            "bistable": run.bistable,
        }
        tip = run.tip_dis
        if options.get("tip", "cap") == "cell":
            tip, kind, status = _cell_tip(run, options)
            row["cap_tip_dis"], row["cap_tip_kind"] = row["tip_dis"], row["tip_kind"]
            row["tip_dis"] = math.nan if tip is None else tip
            row["tip_kind"], row["cell_status"] = kind, status
        designs.append(row)
        if run.status in ("reached", "partial"):
            frame = run.to_frame(curve=f"d{index:06d}")
            if tip is None:
                frame = frame.drop(columns="tip_dis", errors="ignore")
            else:
                frame["tip_dis"] = tip
            frames.append(frame)
    return frames, designs


def _cell_tip(run, options: dict) -> tuple[float | None, str, str]:
    """The dome's inverted travel set in its unit cell's plate: ``(tip_dis, tip_kind, status)``.

    ``tip_dis`` is None (kind "") when the cell has neither a rest nor a ghost, or its run
    failed (``status`` says how).
    """
    from .geometry import cell_plate
    from .shell import PLATE_TRAVEL, unit_cell_curve

    try:
        cell = unit_cell_curve(
            run.H,
            run.t,
            run.r_b,
            run.E,
            run.nu,
            plate=cell_plate(run.r_b),
            travel=max(options["travel"], PLATE_TRAVEL) * run.H,
            n_elements=options["n_elements"],
            max_steps=options["max_steps"],
        )
    except Exception as exc:  # one bad geometry never stops the sweep
        return None, "", f"error: {type(exc).__name__}: {exc}"
    if cell.tip_dis is None:
        return None, "", cell.status
    return float(cell.tip_dis), str(cell.tip_kind), cell.status


def parquet_bytes(frame: pd.DataFrame) -> bytes:
    """A frame as the bytes of a Parquet file (no index), as ``frame.to_parquet`` writes it."""
    sink = BytesIO()
    frame.to_parquet(sink, index=False)
    return sink.getvalue()


@dataclass(frozen=True)
class UnitCellWork:
    """A unit-cell sweep's chunks for the sweep engines (:class:`~dpfexplore.sweep.work.ChunkWork`).

    Workers trace and send back their frames; this process writes them
    (:attr:`write_in_parent`), so the workers of a remote cluster need no shared disk.

    Attributes
    ----------
    root : str
        The ``chunks`` folder of the sweep directory.
    options : dict
        The job's options (``n_elements``, ``travel``, ``max_steps``).
    """

    root: str
    options: dict[str, Any]
    write_in_parent: ClassVar[bool] = True

    def warm_up(self) -> float:
        """Compile the shell kernels (or load them from the cache); returns seconds."""
        from .shell import _announce

        start = time.perf_counter()
        _announce()
        return time.perf_counter() - start

    def compute(self, task: CellTask) -> tuple[list, list]:
        """Trace the chunk's geometries: frames of curves, rows of designs."""
        return _trace_chunk(task.rows, self.options)

    def write(self, task: CellTask, result: tuple[list, list]) -> CellChunk:
        """Write the chunk's files atomically (curves, then designs); returns its record."""
        frames, designs = result
        curves = None
        if frames:
            data = parquet_bytes(pd.concat(frames, ignore_index=True))
            curves = commit_file(self.root, f"{task.path}.curves.parquet", data)
        table = pd.DataFrame(designs)
        written = commit_file(self.root, f"{task.path}.designs.parquet", parquet_bytes(table))
        statuses = Counter(str(row["status"]) for row in designs)
        return CellChunk(task.index, task.start, task.stop, written, curves, dict(statuses))


@dataclass
class ChunkManifest:
    """The commit record of a sweep directory's chunks (``chunks/_manifest.json``).

    Attributes
    ----------
    fingerprint : str
        :attr:`~.sweep.UnitCellJob.fingerprint` of the job that owns the directory.
    job : dict
        The job as read.
    geometries, chunk_size, n_chunks : int
        The plan.
    chunks : dict of str to CellChunk
        Committed chunks by name.
    """

    fingerprint: str
    job: dict[str, Any]
    geometries: int
    chunk_size: int
    n_chunks: int
    chunks: dict[str, CellChunk] = field(default_factory=dict)
    format: str = FORMAT
    created: str = ""
    updated: str = ""

    @property
    def complete(self) -> bool:
        """Every chunk of the plan is committed."""
        return len(self.chunks) == self.n_chunks

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "format": self.format,
            "fingerprint": self.fingerprint,
            "job": self.job,
            "geometries": self.geometries,
            "chunk_size": self.chunk_size,
            "n_chunks": self.n_chunks,
            "complete": self.complete,
            "chunks": {name: chunk.to_dict() for name, chunk in sorted(self.chunks.items())},
            "created": self.created,
            "updated": self.updated,
        }


def write_manifest(root: str | Path, manifest: ChunkManifest) -> None:
    """Replace ``root/_manifest.json`` atomically: the commit point of every chunk it lists."""
    now = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    manifest.created = manifest.created or now
    manifest.updated = now
    write_json(Path(root) / MANIFEST, manifest.to_dict())


def read_manifest(root: str | Path) -> ChunkManifest:
    """The chunk manifest in folder ``root``.

    Raises
    ------
    FileNotFoundError
        If there is none.
    StoreError
        In one line naming the file, if it is unreadable or of another format.
    """
    path = Path(root) / MANIFEST
    data = read_json(path)
    if data.get("format") != FORMAT:
        raise StoreError(f"{path}: format {data.get('format')!r}, this dpfexplore reads {FORMAT!r}")
    try:
        return ChunkManifest(
            fingerprint=str(data["fingerprint"]),
            job=dict(data["job"]),
            geometries=int(data["geometries"]),
            chunk_size=int(data["chunk_size"]),
            n_chunks=int(data["n_chunks"]),
            chunks={str(k): CellChunk.from_dict(v) for k, v in data["chunks"].items()},
            created=str(data.get("created", "")),
            updated=str(data.get("updated", "")),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise StoreError(f"{path}: unreadable manifest ({type(exc).__name__}: {exc})") from None


def chunk_problem(root: str | Path, chunk: CellChunk, task: CellTask | None = None) -> str | None:
    """Why a committed chunk cannot be trusted any more, or None.

    Its record must match its ``task`` of the plan (if given: the same geometries, its files
    under the chunk's names), and each file its size and checksum (a file missing or changed).
    """
    if task is not None:
        names = [f"{task.path}.designs.parquet", f"{task.path}.curves.parquet"]
        if (chunk.index, chunk.start, chunk.stop) != (task.index, task.start, task.stop):
            return f"record of geometries [{chunk.start}, {chunk.stop}) not in the plan"
        if [record.path for record in chunk.files] != names[: len(chunk.files)]:
            return "record names files of another chunk"
    for record in chunk.files:
        problem = verify_file(root, record)
        if problem is not None:
            return f"{record.path} {problem}"
    return None


def plan_problem(manifest: ChunkManifest, geometries: int, chunk_size: int) -> str | None:
    """How the plan ``manifest`` records differs from its job's, or None.

    The fingerprint fixes the job, hence the plan: a difference means the file was edited.
    """
    n_chunks = -(-geometries // chunk_size)
    recorded = (manifest.geometries, manifest.chunk_size, manifest.n_chunks)
    if recorded != (geometries, chunk_size, n_chunks):
        return (
            f"records {manifest.geometries} geometries in {manifest.n_chunks} chunks of "
            f"{manifest.chunk_size}, its job plans {geometries} in {n_chunks} of {chunk_size}"
        )
    return None


def remove_uncommitted(root: str | Path, manifest: ChunkManifest) -> list[Path]:
    """Delete temporary files and chunk files the manifest does not list; returns them.

    Call it only with the directory's lock held, before chunks are computed.
    """
    root = Path(root)
    removed = remove_leftovers(root)
    listed = {record.path for chunk in manifest.chunks.values() for record in chunk.files}
    for path in root.glob("part-*.parquet"):
        if path.name not in listed:  # renamed into place, never committed
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed


def _read_frame(root: Path, record: FileRecord) -> pd.DataFrame:
    data = verified_bytes(root, record, remedy="run the sweep again to recompute it")
    return pd.read_parquet(pa.BufferReader(data))


def merge_chunks(root: str | Path, manifest: ChunkManifest) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every committed chunk's curves and designs, each file checked against its checksum.

    Returns
    -------
    curves : DataFrame
        Every point of every traced path, in chunk order.
    designs : DataFrame
        One row per geometry, by design index.

    Raises
    ------
    StoreError
        Naming the chunk file, if one is missing or changed after it was committed.
    """
    root = Path(root)
    chunks = sorted(manifest.chunks.values(), key=lambda chunk: chunk.index)
    designs = pd.concat(
        [_read_frame(root, chunk.designs) for chunk in chunks], ignore_index=True
    ).sort_values("design", ignore_index=True)
    frames = [_read_frame(root, chunk.curves) for chunk in chunks if chunk.curves is not None]
    curves = (
        pd.concat(frames, ignore_index=True)
        if frames
        else pd.DataFrame(columns=list(CURVE_COLUMNS))
    )
    return curves, designs
