"""One chunk of a sweep: the plan of chunks, and what a worker does with a chunk.

A chunk is ``[start, stop)`` of the sample plan of one number of units ``N``
(:class:`ChunkTask`). :class:`SweepContext` is the sweep's work for the engines
(:class:`~dpfexplore.sweep.work.ChunkWork`): its ``compute`` samples a chunk's designs and
evaluates them through the batch kernels (:func:`evaluate_chunk`), its ``write`` writes one
Parquet file and returns its :class:`~dpfexplore.sweep.storage.store.ChunkRecord`, never touching
the manifest. The engines (:mod:`dpfexplore.sweep.engines`) run it here or on Dask workers, and
the driver (:mod:`dpfexplore.sweep.driver`) commits what they return.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pyarrow as pa

from ..model.design import DesignBatch
from .evaluation import Evaluator
from .sampling import sample_designs
from .space import PER_UNIT_VARIABLES, SHARED_VARIABLES, ComputeSpec, JobSpec
from .storage import store
from .storage.store import ChunkRecord
from .work import ChunkFailure

__all__ = [
    "MAX_CHUNKS",
    "MAX_CHUNK_ROWS",
    "ChunkFailure",
    "ChunkTask",
    "PlanTooLarge",
    "SweepContext",
    "check_plan",
    "dataset_schema",
    "default_chunk_size",
    "design_column_values",
    "evaluate_chunk",
    "plan_chunks",
    "rows_per_design",
    "write_chunk_file",
]

#: Target design-state rows per chunk when the job does not set ``chunk_size``: about 10-20 MB
#: of rows in memory, a few seconds of work on two cores.
TARGET_CHUNK_ROWS = 1 << 15
#: Bounds of the default chunk size, in designs.
MIN_CHUNK_DESIGNS, MAX_CHUNK_DESIGNS = 16, 4096


def rows_per_design(states: str, n_units: int) -> int:
    """Design-state rows of one valid design: 1, ``N + 1`` or ``2^N``."""
    return {"all_inverted": 1, "sequential": n_units + 1, "all": 2**n_units}[states]


def default_chunk_size(compute: ComputeSpec, n_units: int) -> int:
    """Designs per chunk for ``n_units`` when the job does not say.

    About :data:`TARGET_CHUNK_ROWS` rows, clipped to [:data:`MIN_CHUNK_DESIGNS`,
    :data:`MAX_CHUNK_DESIGNS`] designs.
    """
    per = rows_per_design(compute.states, n_units)
    return int(np.clip(TARGET_CHUNK_ROWS // per, MIN_CHUNK_DESIGNS, MAX_CHUNK_DESIGNS))


@dataclass(frozen=True)
class ChunkTask:
    """Designs ``[start, stop)`` of the plan for ``n_units`` units, chunk number ``index``."""

    n_units: int
    index: int
    start: int
    stop: int

    @property
    def path(self) -> str:
        """Relative path of the chunk's file."""
        return store.chunk_path(self.n_units, self.index)

    @property
    def n_designs(self) -> int:
        """Designs in the chunk."""
        return self.stop - self.start


#: Most chunks a sweep plans: each is a task in memory and a record of about 250 bytes in the
#: manifest, which is rewritten at every commit (2^18 chunks: a manifest of some 64 MiB).
MAX_CHUNKS = 1 << 18
#: Most design-state rows of one chunk: a worker holds them in memory at once (2^22 rows of
#: some 60 columns: about 2 GiB).
MAX_CHUNK_ROWS = 1 << 22


class PlanTooLarge(store.StoreError):
    """A job whose plan would not fit: too many chunks, or chunks too large for memory."""


def check_plan(spec: JobSpec, chunk_sizes: Mapping[int, int]) -> None:
    """Refuse a plan too large for memory, from the job's numbers alone (nothing allocated).

    More than :data:`MAX_CHUNKS` chunks, or chunks of more than :data:`MAX_CHUNK_ROWS` rows.

    Raises
    ------
    PlanTooLarge
        One line with the job's numbers and what to change.
    """
    samples = spec.samples_per_n
    count = sum(-(-samples // chunk_sizes[n]) for n in spec.space.n_units)
    if count > MAX_CHUNKS:
        smallest = min(chunk_sizes.values())
        need = -(-samples * len(spec.space.n_units) // MAX_CHUNKS)
        raise PlanTooLarge(
            f"job.samples_per_n = {samples} for {len(spec.space.n_units)} values of N in chunks "
            f"of {smallest} designs: {count} chunks, more than the {MAX_CHUNKS} a sweep plans; "
            f"give a chunk size (job.chunk_size or --chunk-size) >= {need} or fewer samples"
        )
    for n in spec.space.n_units:
        rows = min(chunk_sizes[n], samples) * rows_per_design(spec.compute.states, n)
        if rows > MAX_CHUNK_ROWS:
            per = rows_per_design(spec.compute.states, n)
            raise PlanTooLarge(
                f"chunk size {chunk_sizes[n]}: chunks of {rows} design-state rows at N = {n} "
                f"({per} per design), more than the {MAX_CHUNK_ROWS} a worker holds; give a "
                f"chunk size (job.chunk_size or --chunk-size) <= {max(1, MAX_CHUNK_ROWS // per)}"
            )


def plan_chunks(spec: JobSpec, chunk_sizes: Mapping[int, int]) -> list[ChunkTask]:
    """Every chunk of the job, in (N, start) order (:func:`check_plan` first)."""
    check_plan(spec, chunk_sizes)
    tasks = []
    for n_units in spec.space.n_units:
        size = chunk_sizes[n_units]
        for index, start in enumerate(range(0, spec.samples_per_n, size)):
            tasks.append(ChunkTask(n_units, index, start, min(start + size, spec.samples_per_n)))
    return tasks


def dataset_schema(spec: JobSpec, evaluator: Evaluator) -> pa.Schema:
    """The dataset's schema: design columns, the evaluator's columns, the dataset metadata."""
    fields = [*store.design_fields(spec.max_units), *evaluator.fields(spec.max_units)]
    return store.with_dataset_metadata(pa.schema(fields), store.dataset_metadata(spec))


@dataclass(frozen=True)
class SweepContext:
    """Everything a worker needs to evaluate and write a chunk (picklable).

    The sweep's :class:`~dpfexplore.sweep.work.ChunkWork`: workers write their chunk files
    themselves (``write_in_parent`` is False), so ``root`` must be on a filesystem they share
    with the driver.

    Attributes
    ----------
    spec : JobSpec
    evaluator : Evaluator
    schema : pyarrow.Schema
        The dataset schema (:func:`dataset_schema`).
    root : str
        Sweep directory (on a filesystem the workers share with the driver).
    """

    spec: JobSpec
    evaluator: Evaluator
    schema: pa.Schema
    root: str
    write_in_parent: ClassVar[bool] = False

    def warm_up(self) -> float:
        """Compile (or load from the cache) the evaluator's kernels; returns seconds."""
        return float(self.evaluator.warm_up())

    def compute(self, task: ChunkTask) -> pa.Table:
        """Sample, evaluate and tabulate one chunk (:func:`evaluate_chunk`; no file I/O)."""
        return evaluate_chunk(self.spec, self.evaluator, self.schema, task)

    def write(self, task: ChunkTask, table: pa.Table) -> ChunkRecord:
        """Write a computed chunk atomically (:func:`write_chunk_file`); returns its record."""
        return write_chunk_file(self, task, table)


def design_column_values(spec: JobSpec, batch: DesignBatch, task: ChunkTask) -> dict[str, object]:
    """The design columns of a chunk's designs (one entry per design, not per row)."""
    n_units_list = spec.space.n_units
    offset = n_units_list.index(task.n_units) * spec.samples_per_n
    sample = np.arange(task.start, task.stop, dtype=np.int64)
    columns: dict[str, object] = {
        "design_id": offset + sample,
        "n_units": batch.n_units.astype(np.int8),
        "sample": sample,
    }
    for name in PER_UNIT_VARIABLES:
        columns[name] = getattr(batch, name)
    for name in SHARED_VARIABLES:
        columns[name] = getattr(batch, name)
    columns["problem"] = batch.problems()[1]
    columns["fitted_range"] = batch.in_fitted_range()
    return columns


def evaluate_chunk(
    spec: JobSpec, evaluator: Evaluator, schema: pa.Schema, task: ChunkTask
) -> pa.Table:
    """Sample, evaluate and tabulate one chunk (no file I/O)."""
    batch = sample_designs(spec, task.n_units, task.start, task.stop)
    rows = dict(evaluator(batch))
    index = np.asarray(rows.pop("design_index"), dtype=np.int64)
    missing = np.setdiff1d(np.arange(len(batch)), index)
    if missing.size:  # the contract: every design keeps a row
        raise RuntimeError(f"evaluator returned no row for designs {missing[:5].tolist()} ...")
    columns: dict[str, object] = {}
    for name, values in design_column_values(spec, batch, task).items():
        if isinstance(values, list):
            columns[name] = [values[i] for i in index]
        else:
            columns[name] = np.asarray(values)[index]
    columns.update(rows)
    return store.table_from_columns(schema, columns, n_units=batch.n_units[index])


def write_chunk_file(context: SweepContext, task: ChunkTask, table: pa.Table) -> ChunkRecord:
    """Write a computed chunk atomically; its record carries the row count per status."""
    record = store.write_chunk(context.root, task.n_units, task.index, task.start, task.stop, table)
    if "status_label" in table.column_names:
        counts = table.column("status_label").combine_chunks().dictionary_decode().value_counts()
        statuses = {str(entry["values"]): int(entry["counts"]) for entry in counts.to_pylist()}
        record = dataclasses.replace(record, statuses=dict(sorted(statuses.items())))
    return record
