"""Rebuild a sweep directory's lost manifest from the chunk files that are provably intact.

``_manifest.json`` is a sweep directory's commit record (:mod:`dpfexplore.sweep.storage.store`):
without it, readers and ``--resume`` refuse the directory, and every chunk file in it would be
recomputed. :func:`repair_sweep` (``dpfexplore sweep JOB --out DIR --repair``) writes a new
manifest that commits exactly the chunk files it can verify against the job, and nothing else;
``--resume`` then computes the rest. A chunk file is committed only if

1. it is readable Parquet at a path of the job's layout (``NXX/part-XXXXXX.parquet`` with an
   ``N`` of the job), carrying the identity every chunk is written with (``N``, chunk index,
   designs ``[start, stop)``, rows, a SHA-256 of its decoded contents:
   :func:`~dpfexplore.sweep.storage.store.table_digest`) that agrees with its path;
2. it was written by this job and model version (the dataset metadata in the file: job
   fingerprint and ``model_version``) with this job's schema (every column, its type);
3. its contents hash to that SHA-256: a value changed in place, even in a valid file, fails
   here;
4. its designs are the job's plan: its ``[start, stop)`` lies on the chunk grid of its ``N``
   (one chunk size per ``N``, taken from the intact files), every design of the range has a
   row, and every design column (``design_id``, ``sample``, each unit's ``H``, ``U_L``,
   ``U_sep``, the shared parameters, ``problem``, ``fitted_range``) equals the plan's, design by
   design (the plan is re-sampled, which costs no solve).

The outputs of a verified chunk are trusted because of (3): they are the bytes the worker wrote
and hashed. Files that fail are named with the reason and left in place; ``--resume``
recomputes their chunks and overwrites them.
"""

from __future__ import annotations

import collections
import hashlib
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ..io.lock import sweep_lock
from ..model.version import MODEL_VERSION, package_versions
from .chunks import ChunkTask, dataset_schema, default_chunk_size, design_column_values, plan_chunks
from .evaluation import Evaluator, StaticsEvaluator
from .sampling import sample_designs
from .space import JobSpec
from .storage import store
from .storage.store import ChunkRecord, Manifest, StoreError

__all__ = ["RepairReport", "repair_sweep"]

logger = logging.getLogger(__name__)


@dataclass
class RepairReport:
    """What :func:`repair_sweep` did.

    Attributes
    ----------
    out : Path
    committed : list of str
        Chunk files verified and committed in the new manifest.
    rejected : list of (str, str)
        Chunk files left out, with the reason.
    chunks_total : int
        Chunks of the job's plan (at the chunk sizes of the manifest written).
    designs_committed, n_designs : int
    chunk_sizes : dict of int to int
    """

    out: Path
    committed: list[str] = field(default_factory=list)
    rejected: list[tuple[str, str]] = field(default_factory=list)
    chunks_total: int = 0
    designs_committed: int = 0
    n_designs: int = 0
    chunk_sizes: dict[int, int] = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        """Every chunk of the plan was verified."""
        return len(self.committed) == self.chunks_total


@dataclass
class _Candidate:
    path: str
    data: pa.Buffer
    table: pa.Table
    identity: dict


def _load(out: Path, path: str, spec: JobSpec, schema: pa.Schema) -> _Candidate | str:
    """The chunk file at ``path`` if checks 1-3 of the module docstring pass, else why not."""
    n_units, index = (int(part) for part in store._PART.match(path).groups())
    if n_units not in spec.space.n_units:
        return f"N = {n_units} is not in the job"
    try:
        data = store.read_file_buffer(out / path)
    except store.StoreError as exc:  # not a regular file, or too large for a chunk
        return str(exc).removeprefix(f"chunk {out / path}: ")
    try:
        table = pq.read_table(pa.BufferReader(data))
    except (pa.ArrowException, OSError) as exc:  # pyarrow's errors: the file is damaged
        return f"unreadable ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
    identity = store.chunk_identity(table)
    if identity is None:
        return "carries no chunk identity (damaged, or written by an older dpfexplore)"
    expected = {"n_units": n_units, "index": index, "rows": table.num_rows}
    for key, value in expected.items():
        if identity.get(key) != value:
            return f"its identity says {key} = {identity.get(key)!r}, expected {value!r}"
    meta = store.schema_metadata(table.schema)
    if meta.get("fingerprint") != spec.fingerprint():
        return "written by another job (fingerprint differs)"
    if meta.get("model_version") != MODEL_VERSION:
        return f"written by model version {meta.get('model_version')!r}, this is {MODEL_VERSION!r}"
    if not table.schema.equals(schema, check_metadata=False):
        return "its columns differ from the job's schema"
    if store.table_digest(table) != identity.get("content_sha256"):
        return "its contents differ from the SHA-256 written with them (corrupted)"
    return _Candidate(path, data, table, identity)


def _chunk_size(spec: JobSpec, n_units: int, found: list[_Candidate], given: int | None) -> int:
    """Chunk size of ``n_units`` implied by the intact files (or given, or the job's)."""
    if given is not None:
        return given
    votes: collections.Counter[int] = collections.Counter()
    for c in found:
        start, stop, index = c.identity["start"], c.identity["stop"], c.identity["index"]
        if stop < spec.samples_per_n:  # a full chunk
            votes[stop - start] += 1
        elif index > 0 and start % index == 0:  # the last chunk: size = start / index
            votes[start // index] += 1
    if votes:
        return votes.most_common(1)[0][0]
    size = (
        spec.chunk_size
        if spec.chunk_size is not None
        else default_chunk_size(spec.compute, n_units)
    )
    if any(c.identity["index"] == 0 and c.identity["stop"] == spec.samples_per_n for c in found):
        size = max(size, spec.samples_per_n)  # one chunk held the whole plan of this N
    return size


def _matches_plan(spec: JobSpec, candidate: _Candidate, size: int) -> str | None:
    """Check 4 of the module docstring; None when the chunk is the plan's."""
    ident = candidate.identity
    start, stop, index = ident["start"], ident["stop"], ident["index"]
    if start != index * size or stop != min(start + size, spec.samples_per_n):
        return f"designs [{start}, {stop}) are not chunk {index} of size {size} of the plan"
    table = candidate.table
    sample = table.column("sample").to_numpy()
    if not np.array_equal(np.unique(sample), np.arange(start, stop)):
        return "does not hold one row or more for every design of its range"
    task = ChunkTask(ident["n_units"], index, start, stop)
    batch = sample_designs(spec, task.n_units, start, stop)
    expected = design_column_values(spec, batch, task)
    row = sample - start
    for name, values in expected.items():
        if isinstance(values, list):
            wanted = [values[i] for i in row]
            if table.column(name).to_pylist() != wanted:
                return f"column {name} differs from the plan's designs"
            continue
        values = np.asarray(values)
        if values.ndim == 2:  # per-unit: columns name_1 .. name_maxN
            for k in range(1, spec.max_units + 1):
                got = table.column(f"{name}_{k}").to_numpy(zero_copy_only=False)
                if not np.array_equal(got, values[row, k - 1], equal_nan=True):
                    return f"column {name}_{k} differs from the plan's designs"
            continue
        got = table.column(name).to_numpy(zero_copy_only=False)
        if not np.array_equal(got, values[row].astype(got.dtype)):
            return f"column {name} differs from the plan's designs"
    return None


def _record(candidate: _Candidate) -> ChunkRecord:
    ident = candidate.identity
    statuses: dict[str, int] = {}
    if "status_label" in candidate.table.column_names:
        labels = candidate.table.column("status_label").combine_chunks()
        counts = labels.dictionary_decode().value_counts()
        statuses = {str(e["values"]): int(e["counts"]) for e in counts.to_pylist()}
    return ChunkRecord(
        path=candidate.path,
        n_units=ident["n_units"],
        index=ident["index"],
        start=ident["start"],
        stop=ident["stop"],
        rows=candidate.table.num_rows,
        bytes=candidate.data.size,
        sha256=hashlib.sha256(memoryview(candidate.data)).hexdigest(),
        statuses=dict(sorted(statuses.items())),
    )


def repair_sweep(
    spec: JobSpec,
    out: str | Path,
    *,
    chunk_size: int | None = None,
    evaluator: Evaluator | None = None,
) -> RepairReport:
    """Write a new ``_manifest.json`` for ``out`` committing its verified chunk files.

    Parameters
    ----------
    spec : JobSpec
        The job that made the directory.
    out : path
        The sweep directory, whose manifest is missing or unreadable.
    chunk_size : int, optional
        Designs per chunk (default: what the intact files show, else the job's).
    evaluator : Evaluator, optional
        What the job computes (its columns); the job's own by default.

    Returns
    -------
    RepairReport

    Raises
    ------
    StoreError
        If ``out`` does not exist, still has a readable manifest (``--resume`` checks its
        chunks instead), or another sweep holds it.
    """
    out = Path(out)
    if not out.is_dir():
        raise StoreError(f"--out {out}: no such directory to repair")
    evaluator = evaluator if evaluator is not None else StaticsEvaluator(spec.compute)
    schema = dataset_schema(spec, evaluator)
    with sweep_lock(out):
        if (out / store.MANIFEST).exists():
            try:
                store.read_manifest(out)
            except StoreError:
                pass  # unreadable: rebuild it
            else:
                raise StoreError(
                    f"--out {out}: has a readable {store.MANIFEST}; nothing to repair "
                    "(--resume checks every chunk it lists)"
                )
        report = RepairReport(out=out, n_designs=spec.n_designs)
        by_n: dict[int, list[_Candidate]] = collections.defaultdict(list)
        for path in store.part_files(out):
            loaded = _load(out, path, spec, schema)
            if isinstance(loaded, str):
                report.rejected.append((path, loaded))
            else:
                by_n[loaded.identity["n_units"]].append(loaded)
        sizes = {n: _chunk_size(spec, n, by_n[n], chunk_size) for n in spec.space.n_units}
        manifest = Manifest(
            fingerprint=spec.fingerprint(),
            job=spec.to_dict(),
            result_defining=spec.result_defining(),
            model_version=MODEL_VERSION,
            versions=package_versions(),
            plan={n: spec.samples_per_n for n in spec.space.n_units},
            chunk_sizes=sizes,
        )
        for n_units, candidates in by_n.items():
            for candidate in candidates:
                problem = _matches_plan(spec, candidate, sizes[n_units])
                if problem is not None:
                    report.rejected.append((candidate.path, problem))
                    continue
                manifest.chunks[candidate.path] = _record(candidate)
        tasks = plan_chunks(spec, sizes)
        manifest.complete = len(manifest.chunks) == len(tasks)
        store.write_manifest(out, manifest)
        if not (out / store.COMMON_METADATA).exists():
            store.write_common_metadata(out, schema)
        report.committed = sorted(manifest.chunks)
        report.rejected.sort()
        report.chunks_total = len(tasks)
        report.designs_committed = manifest.n_designs_committed
        report.chunk_sizes = sizes
        for path, why in report.rejected:
            logger.warning("repair: left out %s (%s)", path, why)
        return report
