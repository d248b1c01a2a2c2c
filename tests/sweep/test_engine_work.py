"""The engines run any work (a ChunkWork), here or on local worker processes, written where the
work says; a failing chunk is reported alone; closing after an interruption stops every worker."""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import psutil
import pytest
from sweep_helpers import spawned_workers

from dpfexplore.io.commits import commit_file
from dpfexplore.sweep.engines import LocalEngine
from dpfexplore.sweep.work import ChunkFailure


@dataclass(frozen=True)
class Task:
    index: int
    start: int
    stop: int

    @property
    def path(self) -> str:
        return f"part-{self.index:03d}.json"


@dataclass(frozen=True)
class Record:
    path: str
    start: int
    stop: int
    sha256: str
    writer: int  # pid of the process that wrote the file


@dataclass(frozen=True)
class SquaresWork:
    """A chunk's result is its numbers squared, written as JSON; no kernels."""

    root: str
    write_in_parent: bool = False
    fail: int = -1  # index of a chunk whose compute raises
    seconds: float = 0.0  # sleep per chunk after the first

    def warm_up(self) -> float:
        return 0.0

    def compute(self, task: Task) -> list[int]:
        if task.index == self.fail:
            raise RuntimeError("no squares today")
        if task.index and self.seconds:
            time.sleep(self.seconds)
        return [x * x for x in range(task.start, task.stop)]

    def write(self, task: Task, result: list[int]) -> Record:
        written = commit_file(self.root, task.path, json.dumps(result).encode())
        return Record(task.path, task.start, task.stop, written.sha256, os.getpid())


TASKS = [Task(k, 3 * k, 3 * k + 3) for k in range(5)]


def run(engine: LocalEngine, work: SquaresWork) -> list:
    engine.start(work)
    try:
        return list(engine.run(work, TASKS))
    finally:
        engine.close()


@pytest.mark.parametrize("processes", [1, 2])
@pytest.mark.parametrize("in_parent", [False, True])
def test_any_work_runs_and_is_written_where_it_says(tmp_path, processes, in_parent):
    work = SquaresWork(str(tmp_path), write_in_parent=in_parent)
    outcomes = run(LocalEngine(processes=processes), work)
    assert sorted(o.path for o in outcomes) == [t.path for t in TASKS]
    for task in TASKS:
        values = json.loads((tmp_path / task.path).read_text())
        assert values == [x * x for x in range(task.start, task.stop)]
    writers = {o.writer for o in outcomes}
    if in_parent or processes == 1:
        assert writers == {os.getpid()}
    else:
        assert os.getpid() not in writers
    assert not list(Path(tmp_path).glob(".*.tmp"))


@pytest.mark.parametrize("processes", [1, 2])
def test_a_failing_chunk_is_reported_alone(tmp_path, processes):
    outcomes = run(LocalEngine(processes=processes), SquaresWork(str(tmp_path), fail=2))
    failures = [o for o in outcomes if isinstance(o, ChunkFailure)]
    assert [f.task.index for f in failures] == [2]
    assert "no squares today" in failures[0].error
    assert len(outcomes) == len(TASKS)


def test_close_after_an_interruption_ends_the_worker_processes(tmp_path):
    # Every chunk after the first takes a minute: closing after the first must not wait for them.
    work = SquaresWork(str(tmp_path), write_in_parent=True, seconds=60.0)
    engine = LocalEngine(processes=2)
    before = {p.pid for p in spawned_workers()}
    engine.start(work)
    outcomes = engine.run(work, TASKS)
    first = next(outcomes)
    assert first.path == TASKS[0].path
    workers = [p for p in spawned_workers() if p.pid not in before]
    assert len(workers) == 2
    started = time.perf_counter()
    engine.close()  # as the caller's finally does on Ctrl-C
    assert time.perf_counter() - started < 10.0
    _, alive = psutil.wait_procs(workers, timeout=10.0)
    assert not alive
    assert sorted(p.name for p in tmp_path.iterdir()) == [TASKS[0].path]


def test_processes_must_be_a_positive_integer():
    with pytest.raises(ValueError, match="processes"):
        LocalEngine(processes=0)
