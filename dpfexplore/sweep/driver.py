"""Chunked evaluation of a sweep job into a resumable Parquet dataset.

:func:`run_sweep` is the whole job: it checks the output directory, rebuilds the plan of chunks
from the job, hands the chunks that are not committed yet to an engine
(:mod:`dpfexplore.sweep.engines`: this process, or Dask workers), and commits each finished chunk in
the manifest (:mod:`dpfexplore.sweep.storage.store`). A chunk is ``[start, stop)`` of the sample
plan of one number of units ``N``; the chunk evaluates its designs through the batch kernels
(:func:`run_chunk`), writes one Parquet file, and returns its
:class:`~dpfexplore.sweep.storage.store.ChunkRecord`.

Invariants (tested in ``tests/sweep/test_sweep*.py``)
    * Every design of the plan has at least one row, whatever its fate: an invalid design keeps
      one row with its status (``invalid_input``, ``invalid_constants``) and the reason in
      ``problem``; a state that does not exist keeps its row as ``collapsed``.
    * Rows do not depend on the chunk size, the engine or the number of workers: sampling is
      chunk-invariant (:mod:`dpfexplore.sweep.sampling`) and each row is computed from its own
      design.
    * Resume (``resume=True``) recomputes exactly the chunks the manifest does not list or whose
      files fail their size and checksum test, after removing temporary leftovers and unlisted
      part files; it refuses a directory made by another job or another model version.
    * Peak memory is bounded by the chunk size: a chunk's designs and rows live only while it is
      evaluated and written; the driver keeps only chunk records.
    * One sweep at a time per directory: the whole call holds the directory's lock
      (:mod:`dpfexplore.io.lock`); a second sweep into it refuses, naming the holder.
    * A rerun of a complete directory of the same job (without ``resume``) computes nothing and
      returns its summary; an incomplete one needs ``resume=True``.
    * Ctrl-C (``KeyboardInterrupt``) leaves every committed chunk committed and raises
      :class:`SweepInterrupted`, which says how much that is.
"""

from __future__ import annotations

import collections
import logging
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa

from ..io.files import TEMP_SUFFIX
from ..io.lock import LOCK_NAME, LockHeld, remove_if_empty, sweep_lock
from ..model.constants_set import DEFAULT
from ..model.version import MODEL_VERSION, package_versions
from .chunks import (
    ChunkTask,
    SweepContext,
    dataset_schema,
    default_chunk_size,
    plan_chunks,
)
from .engines import Engine, LocalEngine
from .evaluation import Evaluator, StaticsEvaluator
from .progress import LogProgress, Progress
from .progress import note as _note
from .space import JobSpec
from .storage import store
from .storage.store import ChunkRecord, Manifest, StoreError
from .work import ChunkFailure

__all__ = [
    "LockHeld",
    "LogProgress",
    "Progress",
    "SweepInterrupted",
    "SweepSummary",
    "check_output",
    "run_sweep",
]

logger = logging.getLogger(__name__)


@dataclass
class SweepSummary:
    """What a :func:`run_sweep` call did.

    Attributes
    ----------
    out : Path
    n_designs : int
        Designs in the whole job.
    designs_computed : int
        Designs evaluated by this call (the rest were committed before).
    rows : int
        Committed design-state rows in the dataset.
    chunks_total, chunks_computed, chunks_reused : int
    failures : list of ChunkFailure
        Chunks that could not be computed; the manifest stays incomplete, ``--resume`` retries.
    complete : bool
    statuses : dict of str to int
        Rows per status label in the whole dataset.
    wall_s : float
        Wall time of the call, s.
    timings : dict of str to float
        Phases, s: the engine's (``compile_s``; Dask: ``cluster_start_s``,
        ``worker_warmup_s``, ``cluster_close_s``) and ``chunks_s``, from the first chunk
        submitted to the last one committed.
    engine : str
    """

    out: Path
    n_designs: int
    designs_computed: int = 0
    rows: int = 0
    chunks_total: int = 0
    chunks_computed: int = 0
    chunks_reused: int = 0
    failures: list[ChunkFailure] = field(default_factory=list)
    complete: bool = False
    statuses: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    engine: str = ""


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`run_sweep`: the committed chunks stay committed.

    Attributes
    ----------
    out : Path
    designs_committed, n_designs : int
        Designs committed in the directory, of the job's total.
    chunks_committed, chunks_total : int
    """

    def __init__(self, out: Path, manifest: Manifest, chunks_total: int, n_designs: int):
        self.out = out
        self.designs_committed = manifest.n_designs_committed
        self.n_designs = n_designs
        self.chunks_committed = len(manifest.chunks)
        self.chunks_total = chunks_total
        super().__init__(
            f"interrupted: {self.chunks_committed} of {chunks_total} chunks "
            f"({self.designs_committed} of {n_designs} designs) committed in {out}"
        )


@dataclass
class _Prepared:
    manifest: Manifest
    tasks: list[ChunkTask]
    pending: list[ChunkTask]
    fresh: bool
    dropped: list[tuple[str, str]] = field(default_factory=list)


def _chunk_sizes(spec: JobSpec, chunk_size: int | None) -> dict[int, int]:
    size = chunk_size if chunk_size is not None else spec.chunk_size
    return {
        n: (size if size is not None else default_chunk_size(spec.compute, n))
        for n in spec.space.n_units
    }


def check_output(
    spec: JobSpec, out: str | Path, *, resume: bool = False, chunk_size: int | None = None
) -> _Prepared:
    """Decide what a sweep into ``out`` will do, without writing anything.

    Raises
    ------
    StoreError
        ``out`` holds another job's data, data of another model version, files that are not a
        sweep, or this job's data without ``resume``; or ``chunk_size`` contradicts the
        directory's.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise StoreError(f"--out {out}: exists and is not a directory")
    # A run killed while creating the directory leaves at most temporary files behind (and
    # the lock, which the caller holds).
    has_files = out.is_dir() and any(
        p.name != LOCK_NAME and not (p.name.startswith(".") and p.name.endswith(TEMP_SUFFIX))
        for p in out.iterdir()
    )
    if not has_files:
        sizes = _chunk_sizes(spec, chunk_size)
        manifest = Manifest(
            fingerprint=spec.fingerprint(),
            job=spec.to_dict(),
            result_defining=spec.result_defining(),
            model_version=MODEL_VERSION,
            versions=package_versions(),
            plan={n: spec.samples_per_n for n in spec.space.n_units},
            chunk_sizes=sizes,
        )
        tasks = plan_chunks(spec, sizes)
        return _Prepared(manifest, tasks, list(tasks), fresh=True)
    if not (out / store.MANIFEST).exists():
        hint = ""
        if store.part_files(out):
            hint = (
                f"; it holds chunk files: if its {store.MANIFEST} was deleted, rebuild it with "
                "--repair"
            )
        raise StoreError(
            f"--out {out}: not empty and not a sweep directory (no {store.MANIFEST}){hint}"
        )
    manifest = store.read_manifest(out)
    # A manifest that records no constants set is of the paper's set.
    recorded = {"constants": _paper_set_entry(), **manifest.result_defining}
    key = spec.first_difference(recorded)
    if key is not None:
        if key.startswith("constants"):
            theirs = recorded["constants"]
            raise StoreError(
                f"--out {out}: holds rows computed under constants set {theirs['name']!r} "
                f"({str(theirs['fingerprint'])[:12]}), this job runs under "
                f"{spec.constants.label}; results of two constants sets cannot share a "
                "dataset: choose another --out"
            )
        raise StoreError(
            f"--out {out}: holds another job's data ({key} differs: this job has "
            f"{_lookup(spec.result_defining(), key)!r}, the directory's has "
            f"{_lookup(manifest.result_defining, key)!r}); choose another --out"
        )
    if manifest.model_version != MODEL_VERSION:
        raise StoreError(
            f"--out {out}: written by model version {manifest.model_version!r}, this is "
            f"{MODEL_VERSION!r}; results of two model versions cannot share a dataset"
        )
    if chunk_size is not None and any(s != chunk_size for s in manifest.chunk_sizes.values()):
        raise StoreError(
            f"--chunk-size {chunk_size}: the directory was started with chunk sizes "
            f"{sorted(set(manifest.chunk_sizes.values()))}; resume keeps them"
        )
    tasks = plan_chunks(spec, manifest.chunk_sizes)
    if not resume:
        if not manifest.complete or len(manifest.chunks) != len(tasks):
            raise StoreError(
                f"--out {out}: already holds this job, incomplete ({manifest.n_designs_committed}"
                f" of {spec.n_designs} designs committed); pass --resume to continue it"
            )
        # Complete: nothing to compute. Check that it still is before saying so.
        for path, record in sorted(manifest.chunks.items()):
            problem = store.verify_chunk(out, record)
            if problem is not None:
                raise StoreError(
                    f"--out {out}: holds this job, complete, but chunk {path} is {problem}; "
                    "pass --resume to recompute it"
                )
        return _Prepared(manifest, tasks, [], fresh=False)
    expected = {task.path: task for task in tasks}
    dropped = []
    for path, record in list(manifest.chunks.items()):
        task = expected.get(path)
        if task is None or (record.start, record.stop) != (task.start, task.stop):
            dropped.append((path, "not in the plan"))
            continue
        problem = store.verify_chunk(out, record)
        if problem is not None:
            dropped.append((path, problem))
    pending = [t for t in tasks if t.path not in manifest.chunks or t.path in dict(dropped)]
    return _Prepared(manifest, tasks, pending, fresh=False, dropped=dropped)


def _paper_set_entry() -> dict[str, str]:
    return {"name": DEFAULT.name, "fingerprint": DEFAULT.fingerprint}


def _lookup(data: Mapping, dotted: str) -> object:
    for part in dotted.split("."):
        if not isinstance(data, Mapping) or part not in data:
            return None
        data = data[part]
    return data


def _open_output(out: Path, prepared: _Prepared, schema: pa.Schema) -> None:
    """Create a fresh directory, or clean a resumed one, so that only committed chunks remain."""
    manifest = prepared.manifest
    if not prepared.fresh and not prepared.pending and not prepared.dropped:
        return  # a complete directory, rerun: nothing to clean, nothing to rewrite
    if prepared.fresh:
        out.mkdir(parents=True, exist_ok=True)
        store.remove_leftovers(out)
        # Manifest first: from then on the directory is this job's, whatever happens next.
        store.write_manifest(out, manifest)
        store.write_common_metadata(out, schema)
        return
    for path, why in prepared.dropped:
        logger.warning("resume: recomputing %s (%s)", path, why)
        manifest.chunks.pop(path, None)
    manifest.complete = False
    store.write_manifest(out, manifest)
    removed = store.remove_leftovers(out)
    if removed:
        logger.info("resume: removed %d temporary leftovers", len(removed))
    for rel in store.part_files(out):
        if rel not in manifest.chunks:  # renamed into place, never committed: recomputed
            (out / rel).unlink(missing_ok=True)
    if not (out / store.COMMON_METADATA).exists():
        store.write_common_metadata(out, schema)


def run_sweep(
    spec: JobSpec,
    out: str | Path,
    *,
    resume: bool = False,
    engine: Engine | None = None,
    evaluator: Evaluator | None = None,
    chunk_size: int | None = None,
    progress: Progress | None = None,
) -> SweepSummary:
    """Evaluate a job into a sweep directory (or finish one with ``resume=True``).

    Parameters
    ----------
    spec : JobSpec
    out : path
        Sweep directory; created if absent. It must be empty, hold this job complete (nothing
        is computed then), or (with ``resume``) hold this job.
    resume : bool
        Continue a directory made by the same job and model version.
    engine : Engine, optional
        Where chunks run (:class:`dpfexplore.sweep.engines.LocalEngine` by default).
    evaluator : Evaluator, optional
        What a chunk computes (:class:`~dpfexplore.sweep.evaluation.StaticsEvaluator` of
        ``spec.compute`` by default).
    chunk_size : int, optional
        Designs per chunk for a new directory (overrides the job's ``chunk_size``).
    progress : Progress, optional
        Progress receiver (log lines by default).

    Returns
    -------
    SweepSummary

    Raises
    ------
    StoreError
        If ``out`` cannot be used (see :func:`check_output`; nothing is written then), or
        :class:`~dpfexplore.io.lock.LockHeld` if another sweep holds it.
    SweepInterrupted
        On Ctrl-C (a ``KeyboardInterrupt``), after the sweep has stopped; every chunk
        committed before stays committed.
    """
    started = time.perf_counter()
    out = Path(out)
    evaluator = evaluator if evaluator is not None else StaticsEvaluator(spec.compute)
    engine = engine if engine is not None else LocalEngine()
    progress = progress if progress is not None else LogProgress()
    created = not out.exists()
    try:
        with sweep_lock(out):
            return _run_locked(spec, out, resume, engine, evaluator, chunk_size, progress, started)
    except StoreError:
        if created:  # bad input writes nothing: remove the directory the lock created
            remove_if_empty(out)
        raise


def _run_locked(spec, out, resume, engine, evaluator, chunk_size, progress, started):
    prepared = check_output(spec, out, resume=resume, chunk_size=chunk_size)
    schema = dataset_schema(spec, evaluator)
    _open_output(out, prepared, schema)
    manifest = prepared.manifest
    summary = SweepSummary(
        out=out,
        n_designs=spec.n_designs,
        chunks_total=len(prepared.tasks),
        chunks_reused=len(prepared.tasks) - len(prepared.pending),
        engine=engine.name,
    )
    context = SweepContext(spec=spec, evaluator=evaluator, schema=schema, root=str(out.resolve()))
    remote = getattr(engine, "scheduler", None) is not None
    chunks_s = 0.0
    try:
        try:
            if prepared.pending:
                _note(progress, _start_note(evaluator, engine))
                engine.start(context)
            progress.start(spec.n_designs, manifest.n_designs_committed)
            chunks_started = time.perf_counter()
            try:
                for outcome in engine.run(context, prepared.pending) if prepared.pending else ():
                    if isinstance(outcome, ChunkFailure):
                        logger.error("chunk %s failed: %s", outcome.task.path, outcome.error)
                        summary.failures.append(outcome)
                        continue
                    _commit(out, manifest, outcome, remote=remote)
                    summary.chunks_computed += 1
                    summary.designs_computed += outcome.stop - outcome.start
                    progress.advance(outcome)
            finally:
                progress.close()
                chunks_s = time.perf_counter() - chunks_started
        finally:
            engine.close()
    except KeyboardInterrupt:
        # Every chunk committed so far is in the manifest already; files renamed into place
        # but not committed are removed by the next --resume.
        store.remove_leftovers(out)
        raise SweepInterrupted(out, manifest, len(prepared.tasks), spec.n_designs) from None
    if prepared.pending or prepared.fresh:
        manifest.complete = len(manifest.chunks) == len(prepared.tasks)
        store.write_manifest(out, manifest)
        store.remove_leftovers(out)
    summary.complete = manifest.complete
    summary.rows = manifest.n_rows
    summary.statuses = _status_totals(manifest.chunks.values())
    summary.timings = {**engine.timings, "chunks_s": chunks_s}
    summary.wall_s = time.perf_counter() - started
    return summary


def _start_note(evaluator: Evaluator, engine: Engine) -> str:
    """What the sweep does before its first chunk: compiling (and how long) or loading."""
    groups = getattr(evaluator, "kernel_groups", None)
    notice = None
    if groups is not None:
        from ..solvers.compilation import compile_notice

        notice = compile_notice(groups())
    if notice is not None:
        return f"{notice}; then starting the {engine.name} engine"
    return f"loading the compiled kernels and starting the {engine.name} engine"


def _commit(out: Path, manifest: Manifest, record: ChunkRecord, *, remote: bool) -> None:
    problem = store.verify_chunk(out, record, checksum=False)
    if problem is not None:
        hint = (
            "; with --scheduler, --out must be a directory the workers share with this machine"
            if remote
            else "; was the directory changed by another process?"
        )
        raise StoreError(
            f"chunk {record.path}: a worker reported it written, but here it is {problem}{hint}"
        )
    manifest.chunks[record.path] = record
    store.write_manifest(out, manifest)


def _status_totals(records: Iterable[ChunkRecord]) -> dict[str, int]:
    totals: collections.Counter[str] = collections.Counter()
    for record in records:
        totals.update(record.statuses)
    return dict(sorted(totals.items()))
