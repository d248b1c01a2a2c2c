"""One sweep per directory, checked with real processes: a second sweep refuses naming the
holder; the lock goes with the sweep; a crashed holder's lock is recognised as stale."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from sweep_helpers import UnitConstantsEvaluator, job_dict, toml_text

from dpfexplore.io.lock import LOCK_NAME, LockHeld, read_lock, sweep_lock
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.job_file import load_job
from dpfexplore.sweep.storage import store

TESTS = Path(__file__).parents[1]
# Process A: a real sweep (8 chunks) whose chunks after the second wait until the test creates
# the file ``go`` (the local engine commits chunk k while it computes chunk k + 1), so that it
# holds the lock for as long as the test needs.
HOLDER = """
import os, sys, time
sys.path.insert(0, {tests!r})
from sweep_helpers import UnitConstantsEvaluator
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.job_file import load_job

class Waiting(UnitConstantsEvaluator):
    calls = 0
    def __call__(self, batch):
        Waiting.calls += 1
        deadline = time.monotonic() + 120
        while Waiting.calls > 2 and not os.path.exists({go!r}) and time.monotonic() < deadline:
            time.sleep(0.01)
        return super().__call__(batch)

run_sweep(load_job({job!r}), {out!r}, evaluator=Waiting(), chunk_size=15)
"""


def write_job(tmp_path: Path) -> Path:
    job = tmp_path / "lock.toml"
    job.write_text(toml_text(job_dict(**{"job.name": "lock"})))
    return job


def start_holder(job: Path, out: Path) -> subprocess.Popen:
    code = HOLDER.format(tests=str(TESTS), job=str(job), out=str(out), go=str(out.parent / "go"))
    return subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def wait_for(condition, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def committed(out: Path) -> int:
    try:
        return len(json.loads((out / store.MANIFEST).read_text())["chunks"])
    except (FileNotFoundError, ValueError, KeyError):
        return 0


@pytest.mark.slow
def test_a_second_sweep_refuses_while_the_first_runs_then_the_lock_is_gone(tmp_path):
    job, out = write_job(tmp_path), tmp_path / "out"
    holder = start_holder(job, out)
    wait_for(lambda: committed(out) >= 1, holder)
    # Process B: the real command, even with --resume, must not touch the directory.
    files_before = store.part_files(out)
    second = subprocess.run(
        [sys.executable, "-m", "dpfexplore", "sweep", str(job), "--out", str(out), "--resume"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert holder.poll() is None, "the holder finished before the second sweep tried"
    assert second.returncode == 2, second.stderr
    lines = second.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert "another sweep is using this directory" in lines[0]
    assert f"pid {holder.pid} on {socket.gethostname()}" in lines[0]
    assert set(files_before) <= set(store.part_files(out))  # nothing of A's was removed
    (tmp_path / "go").touch()
    _, err = holder.communicate(timeout=300)
    assert holder.returncode == 0, err
    assert not (out / LOCK_NAME).exists()
    manifest = store.read_manifest(out)
    assert manifest.complete and len(manifest.chunks) == 8


@pytest.mark.slow
def test_the_lock_of_a_killed_sweep_is_stale_and_a_resume_takes_it_over(tmp_path, caplog):
    job, out = write_job(tmp_path), tmp_path / "out"
    holder = start_holder(job, out)
    wait_for(lambda: committed(out) >= 1, holder)
    holder.send_signal(signal.SIGKILL)
    holder.communicate()
    assert read_lock(out)["pid"] == holder.pid  # left behind by the crash
    summary = run_sweep(load_job(job), out, resume=True, evaluator=UnitConstantsEvaluator())
    assert summary.complete and summary.chunks_reused >= 1
    assert "took over a stale lock" in caplog.text
    assert not (out / LOCK_NAME).exists()


def test_a_live_holder_on_this_host_is_never_taken_over(tmp_path):
    out = tmp_path / "out"
    with sweep_lock(out):
        with pytest.raises(LockHeld, match=f"pid {os.getpid()} on"):
            run_sweep(load_job(write_job(tmp_path)), out, evaluator=UnitConstantsEvaluator())
        assert read_lock(out)["pid"] == os.getpid()
    assert read_lock(out) is None


def test_a_holder_on_another_host_is_reported_with_how_to_clear_it(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text(json.dumps({"host": "elsewhere", "pid": 1, "started": 0.0}))
    with pytest.raises(LockHeld, match=r"pid 1 on elsewhere; if that process is gone, remove"):
        run_sweep(load_job(write_job(tmp_path)), out, evaluator=UnitConstantsEvaluator())
