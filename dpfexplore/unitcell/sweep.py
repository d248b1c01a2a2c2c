"""Many dome units: a job of geometries traced in parallel into the identification table.

A job (TOML) names the geometries, as a grid or a Latin hypercube, and the run's options::

    [grid]                      # the Cartesian product of the lists
    H = [3.0, 3.5, 4.0, 4.5, 5.0]
    t = [0.5, 0.75, 1.0]
    r_b = [5.0]
    E = [26.0]
    nu = [0.35]

    # or: [lhs] n = 200, seed = 0, and [low, high] bounds per parameter (a fixed value is
    # [v, v]); sampled by scipy.stats.qmc.LatinHypercube, scaled explicitly.

    [options]                   # all optional
    n_elements = 128
    travel = 2.2                # in dome heights
    chunk = 8                   # geometries per chunk file
    max_steps = 3000
    tip = "cap"                 # or "cell": tip_dis from the dome in its unit cell's plate

:func:`run_unitcell_sweep` traces every geometry with :func:`~.shell.unit_cell_curve` on the
finger sweeps' engines (:mod:`dpfexplore.sweep.engines`): ``workers`` local processes, or a Dask
cluster (``engine="dask"``: a ``LocalCluster`` of ``workers`` processes, or the running
scheduler at ``scheduler``; the workers send their chunks back and this process writes them, so
remote workers need no shared disk). The kernels are compiled in this process first: several
processes writing Numba's cache at once is a known source of crashes.

The sweep holds the directory's lock while it runs (one writer per directory,
:func:`dpfexplore.io.lock.sweep_lock`) and commits each chunk as a finger sweep does: its files
written whole, then recorded with their SHA-256 in ``DIR/chunks/_manifest.json``
(:mod:`.sweep_chunks` has the layout). An interrupted sweep resumes where it stopped when run
again: committed chunks are checked against their checksums and kept, a chunk missing or
changed is recomputed, and a directory of another job is refused (``DIR/job.json`` holds the
job's fingerprint). At the end ``DIR/curves.parquet`` (the table ``identify fit`` reads, every
point of every path with its branch), ``DIR/designs.parquet`` (one row per geometry: status,
message, initial stiffness, first fold, ``tip_dis`` and ``tip_kind``: the inverted rest's
travel, or a monostable dome's ghost's) are merged from the verified chunks and, last,
``DIR/manifest.json`` is written. ``identify`` takes ``tip_dis`` for every curve or for none, so
``curves.parquet`` leaves the column out when some dome has neither a rest nor a ghost
(``designs.parquet`` keeps it, and the manifest counts them). A geometry that is refused
(``invalid``) or fails numerically (``error``) is a row with its status and message; it never
stops the sweep. Any other error is a bug: its chunk fails with the traceback logged, the
others are committed, and the sweep ends incomplete (:class:`SweepIncomplete`).

With ``tip = "cell"`` every dome is traced a second time set in its unit cell's plate (the
square face of side ``3 r_b`` and thickness ``r_b/5``, 1 mm at ``r_b = 5``: the paper's
proportions, :func:`~.geometry.cell_plate`; its outer edge pinned), and that run's inverted
rest (or ghost) is the dome's ``tip_dis`` and ``tip_kind`` (the cap's own are kept as
``cap_tip_dis`` and ``cap_tip_kind``): the reach of the paper's two-unit runs, whose units sat in
their chambers, with the neighbour clear of the dome (the unit-cell guide, "The inverted apex
travel"). The curves stay the cap's: the paper's unit-cell runs pinned the cap at its base.

A directory written by an older dpfexplore, whose chunk files have no manifest to verify them
against, is refused in one line: give a new directory, or remove its ``chunks`` folder to
recompute it there. ``job.json`` is only the directory's label: missing, half-written or edited,
it is written again from the job; the chunk manifest is the authority (its plan must be the
job's, else it is refused naming it; a chunk record out of its place in the plan is recomputed).

Limits, checked before anything is built or allocated: :data:`MAX_GEOMETRIES` geometries (a
grid's product is counted first), :data:`MAX_CHUNKS` chunks, and a ``max_steps`` whose path
arrays fit :data:`~.geometry.MAX_PATH_BYTES` at the job's ``n_elements``. Ctrl-C stops the
sweep at once (the engine ends its workers) and raises :class:`SweepInterrupted`, which says
what is committed.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..io.commits import MANIFEST, StoreError, read_json, remove_leftovers
from ..io.files import atomic_write
from ..io.lock import remove_if_empty, sweep_lock
from ..io.toml_fields import (
    FieldError,
    check_keys,
    choice,
    integer,
    numbers,
    positive,
    read_toml,
    table,
)
from ..sweep.engines import DaskEngine, Engine, LocalEngine
from ..sweep.work import ChunkFailure
from .geometry import check_path_size
from .sweep_chunks import (
    CHUNKS,
    CellTask,
    ChunkManifest,
    UnitCellWork,
    chunk_problem,
    merge_chunks,
    parquet_bytes,
    plan_problem,
    plan_tasks,
    read_manifest,
    remove_uncommitted,
    write_manifest,
)

__all__ = [
    "MAX_CHUNKS",
    "MAX_GEOMETRIES",
    "SweepIncomplete",
    "SweepInterrupted",
    "UnitCellJob",
    "read_job",
    "run_unitcell_sweep",
]

logger = logging.getLogger(__name__)

PARAMETERS = ("H", "t", "r_b", "E", "nu")
_DEFAULTS = {"r_b": 5.0, "E": 26.0, "nu": 0.35}
_UNITS = {"H": "mm", "t": "mm", "r_b": "mm", "E": "MPa", "nu": ""}
_OPTIONS = {"n_elements": 128, "travel": 2.2, "chunk": 8, "max_steps": 3000}
#: Bounds of the integer options (``n_elements`` as :func:`~.shell.unit_cell_curve` takes it).
_INTEGER_OPTIONS = {"n_elements": (4, 5000), "chunk": (1, 1_000_000), "max_steps": (1, 10_000_000)}
#: Most geometries a job plans (a grid's product is counted before it is built): at a few tenths
#: of a second per dome, a million take days on a workstation.
MAX_GEOMETRIES = 1_000_000
#: Most chunks a job plans: the chunk manifest holds a record of about 450 bytes per chunk and
#: is rewritten at every commit (2^14 chunks: some 7 MB).
MAX_CHUNKS = 1 << 14
#: Where a dome's ``tip_dis`` comes from (``options.tip``): its own pinned cap's inverted rest
#: (``"cap"``, the default), or the cap set in its unit cell's plate (``"cell"``).
TIPS = ("cap", "cell")


@dataclass(frozen=True)
class UnitCellJob:
    """The geometries of a sweep and the options of every run.

    Attributes
    ----------
    geometries : ndarray of shape (n, 5)
        ``H, t, r_b`` (mm), ``E`` (MPa), ``nu`` per geometry.
    options : dict
        ``n_elements``, ``travel`` (in dome heights), ``chunk``, ``max_steps``; ``tip`` when
        the job gives it.
    source : dict
        The job as read (recorded in ``job.json``).
    """

    geometries: np.ndarray
    options: dict[str, Any]
    source: dict[str, Any] = field(repr=False)

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the geometries and options: a sweep resumes only under the same job."""
        digest = hashlib.sha256(np.ascontiguousarray(self.geometries).tobytes())
        digest.update(json.dumps(self.options, sort_keys=True).encode())
        return digest.hexdigest()


def _values(table: Mapping[str, Any], where: str, name: str) -> tuple[float, ...]:
    """``table[name]`` (or its default): a finite number or a non-empty list of them."""
    value = table.get(name, _DEFAULTS.get(name))
    values = numbers(value, f"{where}.{name}", length=None, unit=_UNITS[name], one=True)
    if not values:
        raise FieldError(f"{where}.{name} = []: need at least one number")
    return values


def _bounds(table: Mapping[str, Any], name: str) -> tuple[float, float]:
    """``lhs.NAME``: ``[low, high]`` with ``low <= high``, or one number (fixed)."""
    values = _values(table, "lhs", name)
    low, high = (values * 2)[:2]
    if len(values) > 2 or high < low:
        raise FieldError(f"lhs.{name} = {list(values)!r}: give [low, high] with low <= high")
    return low, high


def _options(source: Mapping[str, Any]) -> dict[str, Any]:
    """The ``[options]`` table over the defaults :data:`_OPTIONS`."""
    options = dict(_OPTIONS)
    if "options" not in source:
        return options
    given = table(source, "options")
    check_keys(given, "options", optional=(*_OPTIONS, "tip"))
    for key in given:
        if key == "tip":  # a choice, recorded only when given (older jobs keep their print)
            options[key] = choice(given, "options", key, TIPS)
        elif key == "travel":
            options[key] = positive(given, "options", key, "dome heights")
        else:
            low, high = _INTEGER_OPTIONS[key]
            options[key] = integer(given, "options", key, low=low, high=high)
    try:  # the cap's path; a cell's plate adds segments, checked by its own run
        label = f"options.max_steps = {options['max_steps']}"
        check_path_size(options["n_elements"], options["max_steps"], label)
    except ValueError as exc:
        raise FieldError(str(exc)) from None
    return options


def _check_plan(count: int, where: str, options: Mapping[str, Any]) -> None:
    """Refuse a job of more than :data:`MAX_GEOMETRIES` geometries or :data:`MAX_CHUNKS` chunks.

    Called with the count alone, before any geometry is built.
    """
    if count > MAX_GEOMETRIES:
        raise FieldError(
            f"{where}: {count} geometries, more than the {MAX_GEOMETRIES} a sweep plans; "
            "split the job"
        )
    chunk = options["chunk"]
    chunks = -(-count // chunk)
    if chunks > MAX_CHUNKS:
        raise FieldError(
            f"options.chunk = {chunk}: {count} geometries make {chunks} chunks, more than the "
            f"{MAX_CHUNKS} a sweep plans; give options.chunk >= {-(-count // MAX_CHUNKS)}"
        )


def job_from_dict(source: Mapping[str, Any]) -> UnitCellJob:
    """A job from its TOML tables (module docstring).

    Raises
    ------
    dpfexplore.io.toml_fields.FieldError
        A ``ValueError`` whose one-line message names the dotted key, e.g.
        ``lhs.H = [2.0, 1.0]: give [low, high] with low <= high``.
    """
    check_keys(source, "", optional=("grid", "lhs", "options"))
    if ("grid" in source) == ("lhs" in source):
        raise FieldError("give exactly one of [grid] or [lhs]")
    options = _options(source)
    if "grid" in source:
        grid = table(source, "grid")
        check_keys(grid, "grid", required=("H", "t"), optional=PARAMETERS[2:])
        columns = [_values(grid, "grid", name) for name in PARAMETERS]
        sizes = [len(column) for column in columns]
        _check_plan(math.prod(sizes), "grid (" + " x ".join(map(str, sizes)) + ")", options)
        geometries = np.array(list(itertools.product(*columns)), dtype=float)
    else:
        from scipy.stats import qmc

        lhs = table(source, "lhs")
        check_keys(lhs, "lhs", required=("n", "H", "t"), optional=("seed", *PARAMETERS[2:]))
        n = integer(lhs, "lhs", "n", low=1, high=MAX_GEOMETRIES)
        _check_plan(n, "lhs.n", options)
        seed = integer(lhs, "lhs", "seed", low=0, high=(1 << 63) - 1) if "seed" in lhs else 0
        bounds = [_bounds(lhs, name) for name in PARAMETERS]
        unit = qmc.LatinHypercube(d=len(PARAMETERS), seed=seed).random(n)
        low, high = np.array(bounds).T
        geometries = low + unit * (high - low)
    return UnitCellJob(geometries, options, dict(source))


def read_job(path: str | Path) -> UnitCellJob:
    """Read a job file (TOML).

    Raises
    ------
    dpfexplore.io.toml_fields.FieldError
        A ``ValueError`` in one line naming the file and the entry.
    """
    path = Path(path)
    try:
        source = read_toml(path, "unit-cell job")
    except FileNotFoundError:
        raise FieldError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FieldError(f"{path}: cannot read ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return job_from_dict(source)
    except FieldError as exc:
        raise FieldError(f"{path}: {exc}") from None


class SweepIncomplete(RuntimeError):
    """Chunks that could not be computed or written (a worker died, a full disk).

    The chunks committed stay committed; running the sweep again computes the others.

    Attributes
    ----------
    failures : list of ChunkFailure
    """

    def __init__(self, out: Path, failures: list) -> None:
        self.failures = failures
        first = failures[0]
        super().__init__(
            f"{out}: {len(failures)} chunk(s) failed (first: {first.task.path}: {first.error}); "
            "the others are committed: run the sweep again to retry them"
        )


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C (or the CLI's SIGTERM) during a sweep: the committed chunks stay committed.

    Raised once the workers have stopped and the lock is released; running the sweep again
    continues it.

    Attributes
    ----------
    out : Path
    chunks_committed, chunks_total : int
    geometries_committed, geometries : int
    """

    def __init__(self, out: Path, manifest: ChunkManifest, tasks: list[CellTask]) -> None:
        self.out = out
        self.chunks_committed = len(manifest.chunks)
        self.chunks_total = len(tasks)
        self.geometries_committed = sum(c.stop - c.start for c in manifest.chunks.values())
        self.geometries = manifest.geometries
        super().__init__(
            f"interrupted: {self.chunks_committed} of {self.chunks_total} chunks "
            f"({self.geometries_committed} of {self.geometries} geometries) committed in {out}"
        )


def _make_engine(
    engine: str, workers: int, scheduler: str | None, no_workers_timeout: float | None
) -> Engine:
    if engine == "local":
        return LocalEngine(processes=workers)
    extra = {} if no_workers_timeout is None else {"no_workers_timeout": no_workers_timeout}
    return DaskEngine(scheduler=scheduler, n_workers=workers, **extra)


def run_unitcell_sweep(
    job: UnitCellJob,
    out: str | Path,
    *,
    workers: int = 1,
    progress=None,
    engine: str = "local",
    scheduler: str | None = None,
    no_workers_timeout: float | None = None,
) -> dict[str, Any]:
    """Trace every geometry of ``job`` into ``out`` (module docstring); resumes a partial run.

    Parameters
    ----------
    job : UnitCellJob
    out : str or Path
        The sweep directory: new, or holding a sweep of this job (resumed).
    workers : int
        Worker processes (one: this process).
    progress : callable, optional
        Called as ``progress(done, total)`` (chunks) after each chunk is committed.
    engine : {"local", "dask"}
        ``"local"``: ``workers`` processes here
        (:class:`~dpfexplore.sweep.engines.LocalEngine`); ``"dask"``: a ``LocalCluster`` of
        ``workers`` processes, or the scheduler at ``scheduler`` (``tcp://host:8786``)
        (:class:`~dpfexplore.sweep.engines.DaskEngine`).
    scheduler : str, optional
        With ``engine="dask"``: the address of a running scheduler.
    no_workers_timeout : float, s, optional
        With ``engine="dask"``: how long the cluster may have no worker at all before the
        remaining chunks fail (:class:`~dpfexplore.sweep.engines.DaskEngine`; its default, 600 s,
        if None). The engine says so in one line after a few seconds without workers.

    Returns
    -------
    dict
        The manifest: counts of designs per status, chunk count, paths.

    Raises
    ------
    ValueError
        For bad arguments, or an ``out`` that holds another job's sweep, an older sweep's
        unverifiable chunks, or a file (one line; nothing is written then).
    LockHeld
        If another sweep is writing ``out`` (a :class:`~dpfexplore.io.commits.StoreError`).
    SweepIncomplete
        If chunks failed; the others stay committed.
    SweepInterrupted
        On Ctrl-C (a ``KeyboardInterrupt``), once the workers have stopped; the committed
        chunks stay committed.
    """
    out = Path(out)
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers={workers!r}: must be a positive integer")
    if engine not in ("local", "dask"):
        raise ValueError(f"engine={engine!r}: choose 'local' or 'dask'")
    if scheduler is not None and engine != "dask":
        raise ValueError("scheduler: only with engine='dask'")
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a directory")
    runner = _make_engine(engine, workers, scheduler, no_workers_timeout)
    created = not out.exists()
    try:
        with sweep_lock(out):
            return _run_locked(job, out, runner, progress)
    except (ValueError, OSError):
        if created:  # bad input or a full disk at the start: no empty directory left behind
            remove_if_empty(out)
        raise


def _job_record(out: Path) -> dict[str, Any] | None:
    """What ``out/job.json`` holds, None if it is missing or unreadable."""
    try:
        return read_json(out / "job.json")
    except (FileNotFoundError, StoreError):
        return None


def _open_chunks(out: Path, job: UnitCellJob, tasks: list[CellTask]) -> ChunkManifest:
    """The directory's chunk manifest, checked against ``job``, with only verified chunks in it.

    A new directory gets its manifest (from then on it is this job's) and ``job.json``; a
    resumed one loses the chunks that fail their checks, then temporary and uncommitted files.
    """
    chunks = out / CHUNKS
    record = chunks / MANIFEST
    recompute = f"remove {chunks} to recompute its chunks here, or give a new directory"
    if (out / MANIFEST).exists():
        raise ValueError(f"{out}: is a finger sweep's dataset; give a directory of its own")
    written = _job_record(out)
    marked = None if written is None else written.get("fingerprint")
    try:
        manifest = read_manifest(chunks)
    except FileNotFoundError:
        manifest = None
    except StoreError as exc:
        raise ValueError(f"{exc}; the chunks cannot be verified: {recompute}") from None
    if manifest is None:
        if marked is not None and marked != job.fingerprint:
            raise ValueError(
                f"{out / 'job.json'}: holds a sweep of another job; give a new directory"
            )
        if any(chunks.glob("designs-*.parquet")) or any(chunks.glob("curves-*.parquet")):
            raise ValueError(
                f"{out}: holds chunk files of an older unit-cell sweep, with no {CHUNKS}/"
                f"{MANIFEST} to verify them against; give a new directory, or remove {chunks} "
                "to recompute them here"
            )
        manifest = ChunkManifest(
            fingerprint=job.fingerprint,
            job=job.source,
            geometries=len(job.geometries),
            chunk_size=job.options["chunk"],
            n_chunks=len(tasks),
        )
        chunks.mkdir(parents=True, exist_ok=True)
        write_manifest(chunks, manifest)  # from now on the directory is this job's
    elif manifest.fingerprint != job.fingerprint:
        raise ValueError(f"{record}: holds a sweep of another job; give a new directory")
    else:
        problem = plan_problem(manifest, len(job.geometries), job.options["chunk"])
        if problem is not None:
            raise ValueError(f"{record}: {problem}: the file was edited; {recompute}")
        planned = {task.path: task for task in tasks}
        dropped = False
        for name, chunk in sorted(manifest.chunks.items()):
            task = planned.get(name)
            problem = "not in the plan" if task is None else chunk_problem(chunks, chunk, task)
            if problem is not None:
                logger.warning("unitcell sweep: recomputing chunk %s (%s)", name, problem)
                del manifest.chunks[name]
                dropped = True
        if dropped:
            write_manifest(chunks, manifest)
    remove_uncommitted(chunks, manifest)
    remove_leftovers(out)
    # job.json is the directory's label; the manifest says whose it is: a label missing,
    # half-written or edited is written again
    text = json.dumps({"fingerprint": job.fingerprint, "job": job.source})
    if written != json.loads(text):
        atomic_write(out / "job.json", text)
    return manifest


def _run_locked(job: UnitCellJob, out: Path, engine: Engine, progress) -> dict[str, Any]:
    tasks = plan_tasks(job.geometries, job.options["chunk"])
    chunks = out / CHUNKS
    manifest = _open_chunks(out, job, tasks)
    pending = [task for task in tasks if task.path not in manifest.chunks]
    failures: list[ChunkFailure] = []
    if pending:
        work = UnitCellWork(root=str(chunks.resolve()), options=job.options)
        done = len(tasks) - len(pending)
        try:
            try:
                engine.start(work)  # compile here, before any worker loads the cache
                for outcome in engine.run(work, pending):
                    if isinstance(outcome, ChunkFailure):
                        logger.error(
                            "unitcell sweep: chunk %s failed: %s", outcome.task.path, outcome.error
                        )
                        failures.append(outcome)
                        continue
                    manifest.chunks[outcome.path] = outcome
                    write_manifest(chunks, manifest)
                    done += 1
                    if progress is not None:
                        progress(done, len(tasks))
            finally:
                engine.close()  # stops the workers, at once after an interruption
                remove_leftovers(chunks)
        except KeyboardInterrupt:
            raise SweepInterrupted(out, manifest, tasks) from None
    if failures:
        raise SweepIncomplete(out, failures)
    return _merge(out, job, manifest)


def _merge(out: Path, job: UnitCellJob, manifest: ChunkManifest) -> dict[str, Any]:
    """Write the merged tables and, last, ``manifest.json``; returns the manifest."""
    curves, designs = merge_chunks(out / CHUNKS, manifest)
    without_tip = 0
    if "tip_dis" in curves:
        # identify takes tip_dis for every curve or none: a dome with no rest and no ghost has none
        without_tip = int(curves.groupby("curve")["tip_dis"].first().isna().sum())
        if without_tip:
            curves = curves.drop(columns="tip_dis")
    atomic_write(out / "curves.parquet", parquet_bytes(curves))
    atomic_write(out / "designs.parquet", parquet_bytes(designs))
    summary = {
        "fingerprint": job.fingerprint,
        "designs": len(designs),
        "chunks": manifest.n_chunks,
        "status": {str(k): int(v) for k, v in designs["status"].value_counts().items()},
        "curves": "curves.parquet",
        "curves_without_tip_dis": without_tip,
        "summary": "designs.parquet",
    }
    atomic_write(out / "manifest.json", json.dumps(summary, indent=2) + "\n")
    return summary
