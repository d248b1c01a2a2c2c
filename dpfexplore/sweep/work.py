"""What an engine runs: the work of a chunk, computed and written, whatever the chunk holds.

An engine (:mod:`.engines`) runs *tasks* through a *work* object and never looks inside either.
A finger sweep's work is :class:`~.chunks.SweepContext` (designs sampled, evaluated through the
batch kernels, written as one Parquet file); a unit-cell sweep's is
:class:`~dpfexplore.unitcell.sweep_chunks.UnitCellWork` (geometries traced by the shell model,
written as a designs file and a curves file). The contract (:class:`ChunkWork`):

* a task is picklable and has a ``path``, the name of its chunk (log lines, failures, Dask keys);
* ``warm_up()`` compiles the kernels the chunks call, or loads them from Numba's cache, and
  returns the seconds it took. Engines call it in this process before any worker starts, then
  on each worker before its first chunk, so that no two processes write the cache at once;
* ``compute(task)`` computes a chunk, with no file I/O, and returns its result (picklable);
* ``write(task, result)`` writes the chunk's files atomically, not the manifest, and returns
  the chunk's record (with ``path``, ``start``, ``stop``), which the caller commits;
* ``write_in_parent`` says where ``write`` runs. False: on the worker, which sends back only the
  record (the directory must be on a disk the workers share). True: the worker sends back the
  result and the engine writes it in this process (workers need no shared disk).

:func:`compute_chunk` holds the process's kernel lock around ``compute``: the batch kernels must
not run from two threads of one process at once (Numba's workqueue layer aborts, any layer would
oversubscribe the cores), so a Dask worker with several threads runs its chunks one at a time.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Protocol

__all__ = ["ChunkFailure", "ChunkWork", "compute_chunk", "run_on_worker"]


class ChunkWork(Protocol):
    """What a chunk computes and how its files are written (module docstring)."""

    #: Whether :meth:`write` runs in the engine's process (True) or on the worker (False).
    write_in_parent: bool

    def warm_up(self) -> float:
        """Compile (or load from the cache) the kernels the chunks call; returns seconds."""

    def compute(self, task: Any) -> Any:
        """The chunk's result (picklable; no file I/O)."""

    def write(self, task: Any, result: Any) -> Any:
        """Write the chunk's files atomically (not the manifest); returns its record."""


@dataclass(frozen=True)
class ChunkFailure:
    """A chunk an engine could not complete (after its retries); the run goes on without it.

    Attributes
    ----------
    task
        The chunk's task (its ``path`` names it).
    error : str
        What went wrong, in one line.
    """

    task: Any
    error: str


# The lock every chunk of this process computes under (module docstring).
_PROCESS_LOCK = threading.Lock()


def compute_chunk(work: ChunkWork, task: Any, numba_threads: int | None = None) -> Any:
    """Compute one chunk, holding the process's kernel lock.

    Parameters
    ----------
    work : ChunkWork
    task
        The chunk's task.
    numba_threads : int, optional
        Threads for the batch kernels in this call (``numba.set_num_threads``, which is per
        calling thread); None leaves Numba's setting alone.
    """
    with _PROCESS_LOCK:
        if numba_threads is not None:
            import numba

            numba.set_num_threads(max(1, min(numba_threads, numba.config.NUMBA_NUM_THREADS)))
        return work.compute(task)


def run_on_worker(work: ChunkWork, task: Any, numba_threads: int | None = None) -> Any:
    """What a worker does with a chunk: compute it, and write it unless the parent writes.

    Returns the chunk's record, or (``work.write_in_parent``) its result for the parent to write.
    """
    result = compute_chunk(work, task, numba_threads)
    return result if work.write_in_parent else work.write(task, result)
