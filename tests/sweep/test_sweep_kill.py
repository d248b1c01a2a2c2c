"""SIGKILL a real ``python -m dpfexplore sweep`` at several points, resume, and compare with an
uninterrupted run: same rows, no duplicates, same values."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from sweep_helpers import job_dict, toml_text

from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.job_file import load_job
from dpfexplore.sweep.storage import store

# 3 x 8 chunks of 50 designs, sequential states: tens of milliseconds per chunk, a few seconds
# in all, so that kills land while chunks are being computed and committed.
JOB = job_dict(
    **{
        "job.name": "kill",
        "job.samples_per_n": 400,
        "job.chunk_size": 50,
        "space.n_units": [5, 6, 7],
        "compute.states": "sequential",
        "compute.min_eig": True,
    }
)
KEY = ["design_id", "requested"]


def committed(out: Path) -> int:
    try:
        return len(json.loads((out / store.MANIFEST).read_text())["chunks"])
    except (FileNotFoundError, json.JSONDecodeError, KeyError):
        return 0


def start_sweep(job: Path, out: Path, *, resume: bool) -> subprocess.Popen:
    command = [sys.executable, "-m", "dpfexplore", "sweep", str(job), "--out", str(out)]
    if resume:
        command.append("--resume")
    return subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def kill_after(proc: subprocess.Popen, out: Path, chunks: int | None, delay: float) -> bool:
    """SIGKILL ``proc`` once ``chunks`` chunks are committed (or after ``delay`` s if None).

    Returns whether it was still running when killed.
    """
    deadline = time.monotonic() + 120
    started = time.monotonic()
    while proc.poll() is None and time.monotonic() < deadline:
        if chunks is None and time.monotonic() - started >= delay:
            break
        if chunks is not None and committed(out) >= chunks:
            break
        time.sleep(0.002)
    alive = proc.poll() is None
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    return alive


@pytest.mark.slow
def test_sigkill_at_several_points_then_resume(tmp_path):
    job = tmp_path / "kill.toml"
    job.write_text(toml_text(JOB))
    reference = tmp_path / "reference"
    run_sweep(load_job(job), reference)
    expected = store.read_results(reference).sort_values(KEY).reset_index(drop=True)

    out = tmp_path / "out"
    # Kill while starting up (before or while the directory is created), then after 1, 7 and 16
    # committed chunks, resuming each time.
    points = [(None, 0.3), (1, 0), (7, 0), (16, 0)]
    killed_running = 0
    progress = []
    for i, (chunks, delay) in enumerate(points):
        proc = start_sweep(job, out, resume=i > 0)
        killed_running += kill_after(proc, out, chunks, delay)
        progress.append(committed(out))
    assert killed_running >= 3, "the sweep finished before most kills: make the job longer"
    assert progress == sorted(progress) and progress[-1] >= 16, progress

    before = committed(out)
    proc = start_sweep(job, out, resume=True)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    # Committed chunks survive a SIGKILL intact: resume reuses every one of them.
    assert f"{before} of 24 chunks reused" in stdout, stdout
    manifest = store.read_manifest(out)
    assert manifest.complete and len(manifest.chunks) == 24
    assert not list(out.rglob("*.tmp"))

    frame = store.read_results(out).sort_values(KEY).reset_index(drop=True)
    assert not frame.duplicated(KEY).any()
    pd.testing.assert_frame_equal(frame, expected)
    # No stray file either: the whole directory, read by pandas, is the same dataset.
    whole = pd.read_parquet(out).sort_values(KEY).reset_index(drop=True)
    pd.testing.assert_frame_equal(whole, expected, check_dtype=False, check_categorical=False)
