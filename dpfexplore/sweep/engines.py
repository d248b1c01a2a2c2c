"""Where a sweep's chunks run: this process, local worker processes, or Dask workers.

:class:`LocalEngine` runs them here (or on ``processes`` local worker processes),
:class:`DaskEngine` on Dask distributed workers.

An engine takes a *work* object (:class:`~dpfexplore.sweep.work.ChunkWork`: what a chunk
computes and how its files are written) and the chunks still to do, computes and writes each,
and yields the chunk's record per finished chunk (in completion order) or a
:class:`~dpfexplore.sweep.work.ChunkFailure` for a chunk that failed every attempt. It knows
nothing of what a chunk holds: finger sweeps (:class:`~dpfexplore.sweep.chunks.SweepContext`)
and unit-cell sweeps (:class:`~dpfexplore.unitcell.sweep_chunks.UnitCellWork`) run on the same
engines. The caller (:func:`~dpfexplore.sweep.driver.run_sweep`,
:func:`~dpfexplore.unitcell.sweep.run_unitcell_sweep`) commits what it receives; engines never
touch the manifest.

Threads, processes and the Numba cache
    The batch kernels parallelise over designs with ``prange``. Entering them from several
    threads of one process at once aborts under Numba's ``workqueue`` layer and oversubscribes
    the cores under any layer, so the project runs one kernel call per process at a time
    (:func:`dpfexplore.sweep.work.compute_chunk` enforces it even in a multi-threaded Dask worker)
    and parallelises across processes:

    * :class:`LocalEngine`: chunks one after another in this process, each on all cores; or,
      for work whose chunks run on one core (the unit-cell shell), on ``processes`` worker
      processes started by ``spawn``, each with ``cores // processes`` Numba threads.
    * :class:`DaskEngine`: worker *processes* with one thread each, and
      ``cores // workers_on_the_host`` Numba threads per worker (``NUMBA_NUM_THREADS`` in the
      environment of a LocalCluster's workers, ``numba.set_num_threads`` in every task), so
      that workers x threads never exceeds the cores.

    Kernels are compiled in the parent before any worker starts (the work's ``warm_up``, e.g.
    :func:`dpfexplore.sweep.warmup.compile_kernels`); local worker processes and the workers of
    a LocalCluster inherit ``NUMBA_CACHE_DIR`` and load the cached machine code (reading only).
    Workers of an existing cluster (``--scheduler``) may run on machines whose cache is cold;
    they warm up one at a time, so no two processes ever write the cache at once.

Faults
    A worker that dies mid-chunk loses nothing committed: its temporary file is never renamed,
    the scheduler reschedules the chunk on another worker (Dask's ``allowed-failures``), and the
    engine resubmits a chunk that still fails, up to ``max_attempts`` in all; a chunk that
    fails them all (one that crashes every process it runs in) is reported as a
    :class:`~dpfexplore.sweep.chunks.ChunkFailure` and the others go on. The chunk's file name is
    deterministic, so a repeated chunk overwrites, never duplicates. Repeated worker deaths can
    leave a LocalCluster without workers (its nannies give up); the engine then scales it back
    up, and if no worker at all is seen for ``no_workers_timeout`` seconds it reports the
    remaining chunks as failed instead of waiting forever (``--resume`` continues).
    Workers that join an existing cluster later load or compile the kernels on their first
    chunk; only then could two processes on one machine compile at once. A local worker process
    that dies fails the chunks it had not finished (``BrokenProcessPool``); they are reported
    as failures and a rerun computes them.

Stopping
    :meth:`Engine.close` ends the workers: after a complete run it waits for them to exit; after
    an interruption (Ctrl-C, an error in the caller) it cancels the chunks not started and
    terminates local worker processes at once, so that nothing computes on after the caller
    has stopped and no process is left behind. A caller that dies without closing (SIGKILL, or
    SIGTERM with no handler) cannot end them: each local worker process watches its parent
    (:data:`PARENT_POLL_S`) and exits as soon as it is gone. The workers of a LocalCluster end
    with it the same way (Dask's own watch of the parent).
"""

from __future__ import annotations

import abc
import logging
import os
import re
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import (
    CancelledError,
    Future,
    ProcessPoolExecutor,
    ThreadPoolExecutor,
    as_completed,
)
from functools import partial
from typing import Any

from .work import _PROCESS_LOCK, ChunkFailure, ChunkWork, compute_chunk, run_on_worker

__all__ = ["DaskEngine", "Engine", "LocalEngine", "make_engine"]

logger = logging.getLogger(__name__)
_DASK_LOG = logging.getLogger("distributed")


class Engine(abc.ABC):
    """Runs chunks; see the module docstring.

    The caller calls :meth:`start` (compile, start workers), then :meth:`run`, then
    :meth:`close` (always, also after an error).

    Attributes
    ----------
    name : str
    timings : dict of str to float
        Seconds spent in the engine's phases (``compile_s`` always).
    """

    name = "engine"

    def __init__(self) -> None:
        self.timings: dict[str, float] = {}

    def start(self, work: ChunkWork) -> None:
        """Compile the kernels (in this process) and get the workers ready."""
        self.timings = {"compile_s": float(work.warm_up())}

    @abc.abstractmethod
    def run(self, work: ChunkWork, tasks: Sequence[Any]) -> Iterator[Any]:
        """Run every task; yield one record or :class:`ChunkFailure` per task as they finish."""

    def close(self) -> None:  # noqa: B027 - engines without resources need nothing here
        """Release workers and connections."""


class LocalEngine(Engine):
    """Chunks in this process, one after another, or on local worker processes.

    With one process (the default), each chunk's kernels run here on ``threads`` cores, and a
    chunk's files are written on a second thread while the next chunk is computed (both
    release the GIL), so the cores are not idle during I/O; at most two chunks' results are in
    memory. With ``processes > 1``, chunks run on that many worker processes (``spawn``), each
    warmed up from the cache this process filled; for work whose chunks each run on one core.

    Parameters
    ----------
    threads : int, optional
        Numba threads per process (default: Numba's, i.e. all cores or ``NUMBA_NUM_THREADS``,
        in this process; ``cores // processes`` in each worker process).
    processes : int
        Worker processes; 1 runs the chunks in this process.
    """

    name = "local"

    def __init__(self, threads: int | None = None, processes: int = 1) -> None:
        super().__init__()
        if threads is not None and threads < 1:
            raise ValueError(f"threads = {threads}: must be >= 1")
        if not isinstance(processes, int) or processes < 1:
            raise ValueError(f"processes = {processes!r}: must be an integer >= 1")
        self.threads = threads
        self.processes = processes
        self._pool: ProcessPoolExecutor | None = None
        self._finished = False

    def start(self, work: ChunkWork) -> None:  # noqa: D102
        super().start(work)  # compile here, before any worker process exists
        self._finished = False
        if self.processes > 1:
            from multiprocessing import get_context

            threads = self.threads or max(1, (os.cpu_count() or 1) // self.processes)
            self._pool = ProcessPoolExecutor(
                self.processes,
                mp_context=get_context("spawn"),
                initializer=_start_process,
                initargs=(work, threads, os.getpid()),
            )

    def run(self, work: ChunkWork, tasks: Sequence[Any]) -> Iterator[Any]:  # noqa: D102
        if self._pool is not None:
            yield from self._run_on_processes(self._pool, work, tasks)
        else:
            yield from self._run_here(work, tasks)
        self._finished = True

    def _run_here(self, work: ChunkWork, tasks: Sequence[Any]) -> Iterator[Any]:
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="dpfexplore-writer") as writer:
            writing: tuple[Any, Future] | None = None
            for task in tasks:
                try:
                    result = compute_chunk(work, task, self.threads)
                except Exception as exc:  # one broken chunk must not stop the night's job
                    logger.exception("chunk %s failed", task.path)
                    yield ChunkFailure(task, f"{type(exc).__name__}: {exc}")
                    continue
                submitted = (task, writer.submit(work.write, task, result))
                del result
                if writing is not None:
                    yield _written(writing[0], writing[1].result)
                writing = submitted
            if writing is not None:
                yield _written(writing[0], writing[1].result)

    @staticmethod
    def _run_on_processes(
        pool: ProcessPoolExecutor, work: ChunkWork, tasks: Sequence[Any]
    ) -> Iterator[Any]:
        futures = {pool.submit(run_on_worker, work, task): task for task in tasks}
        for future in as_completed(futures):
            task = futures.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # a chunk that raised, or a worker process that died
                yield ChunkFailure(task, f"{type(exc).__name__}: {exc}")
                continue
            if work.write_in_parent:
                yield _written(task, partial(work.write, task, outcome))
            else:
                yield outcome

    def close(self) -> None:
        """Stop the worker processes: wait for them after a complete run, else terminate them."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if self._finished:
            pool.shutdown(wait=True)
            return
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            if process.is_alive():
                process.terminate()
        for process in processes:
            process.join(timeout=5.0)


#: Seconds between a local worker process's checks that its parent is alive.
PARENT_POLL_S = 0.2


def _start_process(work: ChunkWork, threads: int, parent: int) -> None:
    """Initializer of a local worker process: its Numba threads, then the kernels from the cache.

    The process ignores SIGINT: Ctrl-C reaches the whole process group, and the parent, which
    handles it, ends its workers (:meth:`LocalEngine.close`). It exits by itself once its
    parent (pid ``parent``) is gone (:func:`_exit_with_parent`).
    """
    import signal

    import numba

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _exit_with_parent(parent)
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    work.warm_up()


def _exit_with_parent(parent: int) -> threading.Thread:
    """End this process within :data:`PARENT_POLL_S` of its parent's death; returns the watcher.

    A killed parent cannot terminate its workers, and a worker of a ``ProcessPoolExecutor``
    waiting for its next chunk would wait forever (it holds its task queue's write end too, so
    it never sees the end of it). The watcher is a daemon thread: the kernels release the GIL,
    so it runs while a chunk computes. ``os._exit``: nothing of the worker's is worth flushing
    (its chunk is not committed; the parent's successor recomputes it).
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    watcher = threading.Thread(target=watch, name="dpfexplore-parent-watch", daemon=True)
    watcher.start()
    return watcher


def _written(task: Any, write: Callable[[], Any]) -> Any:
    """The record ``write()`` returns, or the chunk's failure (one line for an OSError)."""
    try:
        return write()
    except OSError as exc:  # a full disk, a lost mount: the caller logs one line per chunk
        return ChunkFailure(task, f"cannot write the chunk ({exc.strerror or exc})")
    except Exception as exc:  # a bug: keep its traceback
        logger.exception("writing chunk %s failed", task.path)
        return ChunkFailure(task, f"{type(exc).__name__}: {exc}")


def _run_chunk_on_worker(
    work: ChunkWork, task: Any, threads_by_host: dict[str, int], default: int
) -> Any:
    from distributed import get_worker
    from distributed.comm.addressing import get_address_host

    host = get_address_host(get_worker().address)
    return run_on_worker(work, task, threads_by_host.get(host, default))


def _warm_worker(work: ChunkWork, threads: int) -> dict[str, Any]:
    """Load the kernels from the cache on one worker; report its Numba settings."""
    import numba

    with _PROCESS_LOCK:
        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
        seconds = float(work.warm_up())
        try:
            layer = numba.threading_layer()
        except ValueError:  # no parallel region ran (an evaluator without batch kernels)
            layer = "not initialised"
        return {
            "pid": os.getpid(),
            "warm_up_s": seconds,
            "numba_threads": numba.get_num_threads(),
            "numba_max_threads": numba.config.NUMBA_NUM_THREADS,
            "threading_layer": layer,
            "cache_dir": numba.config.CACHE_DIR,
            "cores": os.cpu_count(),
        }


class DaskEngine(Engine):
    """Chunks on Dask distributed worker processes.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``). Its workers must see ``--out`` at
        the same path (a shared filesystem) and have dpfexplore installed. None starts a
        :class:`distributed.LocalCluster` for the run and stops it afterwards.
    n_workers : int, optional
        Worker processes of the LocalCluster (default: one per core). Ignored with
        ``scheduler``.
    max_attempts : int
        Submissions of a chunk before it is reported as failed (a worker death the scheduler
        already retried counts once).
    no_workers_timeout : float, s
        How long the cluster may have no worker at all before the remaining chunks are
        reported as failed (the sweep then ends; ``--resume`` continues it). A LocalCluster
        that lost its workers is scaled back up meanwhile.

    Notes
    -----
    A LocalCluster starts its workers with ``spawn``, which re-imports the calling script:
    a script that runs a Dask sweep must do so under ``if __name__ == "__main__":`` (the
    ``dpfexplore`` command needs nothing).
    """

    name = "dask"

    def __init__(
        self,
        scheduler: str | None = None,
        n_workers: int | None = None,
        *,
        max_attempts: int = 3,
        no_workers_timeout: float = 600.0,
    ) -> None:
        super().__init__()
        if n_workers is not None and n_workers < 1:
            raise ValueError(f"n_workers = {n_workers}: must be >= 1")
        if max_attempts < 1:
            raise ValueError(f"max_attempts = {max_attempts}: must be >= 1")
        if not no_workers_timeout > 0:
            raise ValueError(f"no_workers_timeout = {no_workers_timeout}: must be > 0 s")
        self.scheduler = scheduler
        self.n_workers = n_workers
        self.max_attempts = max_attempts
        self.no_workers_timeout = float(no_workers_timeout)
        self._n_workers = n_workers or os.cpu_count() or 1
        #: Per-worker facts gathered at warm-up (pid, Numba threads, threading layer, ...).
        self.worker_info: dict[str, dict[str, Any]] = {}
        self._client = None
        self._cluster = None
        self._log_level: int | None = None
        self._threads: tuple[dict[str, int], int] = ({}, 1)

    def start(self, work: ChunkWork) -> None:  # noqa: D102
        from distributed import Client

        super().start(work)  # compile in the parent, before any worker exists
        # Dask's scheduler logs every connection at INFO, which drowns a sweep's progress
        # lines once they propagate to the root handler; WARNING and above still show.
        self._log_level = _DASK_LOG.level
        _DASK_LOG.setLevel(max(_DASK_LOG.getEffectiveLevel(), logging.WARNING))
        begin = time.perf_counter()
        if self.scheduler is None:
            self._cluster = self._start_local_cluster()
            self._client = Client(self._cluster)
        else:
            self._client = Client(self.scheduler, timeout="30s")
        self.timings["cluster_start_s"] = time.perf_counter() - begin
        self._threads = self._numba_threads(self._client)
        begin = time.perf_counter()
        self._warm_workers(self._client, work, *self._threads)
        self.timings["worker_warmup_s"] = time.perf_counter() - begin

    def run(self, work: ChunkWork, tasks: Sequence[Any]) -> Iterator[Any]:  # noqa: D102
        if self._client is None:
            raise RuntimeError("DaskEngine.run before start")
        yield from self._execute(self._client, work, tasks, *self._threads)

    def close(self) -> None:  # noqa: D102
        begin = time.perf_counter()
        try:
            if self._client is not None:
                self._client.close()
                self._client = None
            if self._cluster is not None:
                self._cluster.close()
                self._cluster = None
                self.timings["cluster_close_s"] = time.perf_counter() - begin
        finally:
            if self._log_level is not None:
                _DASK_LOG.setLevel(self._log_level)
                self._log_level = None

    def _start_local_cluster(self):
        import numba
        from distributed import LocalCluster

        cores = os.cpu_count() or 1
        n_workers = self._n_workers
        env = {"NUMBA_NUM_THREADS": str(max(1, cores // n_workers))}
        if numba.config.CACHE_DIR:
            env["NUMBA_CACHE_DIR"] = str(numba.config.CACHE_DIR)
        logger.info("starting a LocalCluster of %d worker processes (%s)", n_workers, env)
        return LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env=env,
            silence_logs=logging.ERROR,
        )

    @staticmethod
    def _numba_threads(client) -> tuple[dict[str, int], int]:
        """Numba threads per worker on each host: the host's cores over its worker processes."""
        from distributed.comm.addressing import get_address_host

        cores = client.run(os.cpu_count)
        per_host: dict[str, list[int]] = {}
        for address, count in cores.items():
            per_host.setdefault(get_address_host(address), []).append(count or 1)
        threads = {host: max(1, counts[0] // len(counts)) for host, counts in per_host.items()}
        for address, info in client.scheduler_info()["workers"].items():
            if info.get("nthreads", 1) > 1:
                logger.warning(
                    "worker %s has %d threads; its chunks run one at a time (start workers with "
                    "--nthreads 1 to use the cores through worker processes)",
                    address,
                    info["nthreads"],
                )
        return threads, 1

    def _warm_workers(self, client, work, threads_by_host, default) -> None:
        from distributed.comm.addressing import get_address_host

        self.worker_info = {}
        workers = sorted(client.scheduler_info()["workers"])
        if self._cluster is not None:
            # Our own LocalCluster: same machine, same cache directory, which the parent has
            # just filled, so the workers only read it and may load it all at once.
            threads = max(threads_by_host.values(), default=default)
            self.worker_info.update(client.run(_warm_worker, work, threads, workers=workers))
            return
        # Somebody else's workers may find the cache cold (another machine, another CPU) and
        # compile: one worker at a time, so that no two processes write the cache at once.
        for address in workers:
            threads = threads_by_host.get(get_address_host(address), default)
            self.worker_info.update(client.run(_warm_worker, work, threads, workers=[address]))

    def _execute(self, client, work, tasks, threads_by_host, default):
        from distributed import wait

        token = uuid.uuid4().hex[:8]
        submitted: dict[str, tuple[Any, int]] = {}

        def submit(task: Any, attempt: int):
            key = f"dpfexplore-chunk-{token}-{_key_name(task.path)}-a{attempt}"
            future = client.submit(
                _run_chunk_on_worker,
                work,
                task,
                threads_by_host,
                default,
                key=key,
                pure=False,
            )
            submitted[future.key] = (task, attempt)
            return future

        pending = {submit(task, 1) for task in tasks}
        idle_since: float | None = None
        warned = False
        while pending:
            try:
                done, pending = wait(pending, timeout=_POLL_S, return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            for future in done:
                task, attempt = submitted.pop(future.key)
                try:
                    # Even a finished future can fail here: if its worker dies after the task,
                    # its result is lost and the scheduler reruns the task.
                    record = future.result()
                except (Exception, CancelledError) as error:
                    message = f"{type(error).__name__}: {error}"
                    if attempt < self.max_attempts:
                        logger.warning(
                            "chunk %s attempt %d failed (%s); resubmitting",
                            task.path,
                            attempt,
                            message,
                        )
                        pending.add(submit(task, attempt + 1))
                    else:
                        yield ChunkFailure(task, message)
                    continue
                finally:
                    future.release()
                if work.write_in_parent:  # the worker sent the result back: write it here
                    yield _written(task, partial(work.write, task, record))
                else:
                    yield record
            if done or client.nthreads():
                idle_since, warned = None, False
                continue
            # No worker at all. Workers that die again and again (a chunk that crashes its
            # process) can make a LocalCluster give up on them: start new ones. Somebody
            # else's cluster may get workers back, or not: wait no_workers_timeout for them.
            if self._cluster is not None:
                self._cluster.scale(self._n_workers)
            idle_since = idle_since if idle_since is not None else time.monotonic()
            idle = time.monotonic() - idle_since
            if not warned and idle >= _NO_WORKER_NOTICE_S:
                warned = True  # one line, not one per poll: the user sees why nothing moves
                logger.warning(
                    "the Dask cluster %s has no worker; waiting up to %g s for one, then the "
                    "%d remaining chunk(s) fail (committed chunks are kept; Ctrl-C stops)",
                    self.scheduler or "(local)",
                    self.no_workers_timeout,
                    len(pending),
                )
            if idle > self.no_workers_timeout:
                message = f"no Dask worker for {self.no_workers_timeout:g} s"
                for future in pending:
                    task, _ = submitted.pop(future.key)
                    future.cancel()
                    yield ChunkFailure(task, message)
                return


#: Seconds between checks for workers while no chunk finishes.
_POLL_S = 2.0
#: Seconds without any worker before the engine says so (a LocalCluster's nannies restart a
#: killed worker within this; longer, and the cluster has lost its workers).
_NO_WORKER_NOTICE_S = 5.0


def _key_name(path: str) -> str:
    """A chunk's path as part of a Dask key (``N05/part-000012.parquet`` -> ``N05-part-000012``)."""
    return re.sub(r"[^A-Za-z0-9]+", "-", path.removesuffix(".parquet")).strip("-")


def make_engine(name: str, *, workers: int | None = None, scheduler: str | None = None) -> Engine:
    """Engine by CLI name: ``"local"`` (``workers`` = Numba threads) or ``"dask"``.

    Raises
    ------
    ValueError
        For an unknown name, ``scheduler`` with the local engine, or ``workers < 1``.
    """
    if workers is not None and workers < 1:
        what = "Numba threads" if name == "local" else "Dask worker processes"
        raise ValueError(f"--workers {workers}: must be >= 1 ({what})")
    if name == "local":
        if scheduler is not None:
            raise ValueError(f"--scheduler {scheduler}: only with --engine dask")
        return LocalEngine(threads=workers)
    if name == "dask":
        return DaskEngine(scheduler=scheduler, n_workers=workers)
    raise ValueError(f"--engine {name!r}: choose 'local' or 'dask'")
