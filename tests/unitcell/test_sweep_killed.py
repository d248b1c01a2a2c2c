"""A real ``dpfexplore unitcell sweep --workers 2`` SIGKILLed: its worker processes end with it,
and the next run keeps what was committed (one subprocess, the smallest grid that proves it)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pandas as pd
import psutil
import pytest
from sweep_helpers import spawned_workers

from dpfexplore.unitcell.sweep import job_from_dict, run_unitcell_sweep

JOB = {"grid": {"H": [3.0, 3.5, 4.0, 4.5], "t": [0.8]}, "options": {"n_elements": 32, "chunk": 1}}
JOB_TOML = "[grid]\nH = [3.0, 3.5, 4.0, 4.5]\nt = [0.8]\n[options]\nn_elements = 32\nchunk = 1\n"


@pytest.mark.slow
def test_sigkill_of_the_parent_leaves_no_worker_and_the_next_run_completes(tmp_path):
    job, out = tmp_path / "job.toml", tmp_path / "sw"
    job.write_text(JOB_TOML)
    argv = [sys.executable, "-m", "dpfexplore", "unitcell", "sweep", str(job), "--out", str(out)]
    process = subprocess.Popen(
        [*argv, "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    parent = psutil.Process(process.pid)
    workers: list[psutil.Process] = []
    deadline = time.monotonic() + 120
    try:
        while len(workers) < 2 and time.monotonic() < deadline and process.poll() is None:
            workers = spawned_workers(parent)
            time.sleep(0.02)
        # everything it started: the workers and multiprocessing's resource tracker
        family = parent.children(recursive=True)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert len(workers) == 2, "the sweep ended before its workers were seen"
    # a worker still starting ends once it reaches its initializer, the others within 0.2 s
    _, alive = psutil.wait_procs(family, timeout=15)
    for orphan in alive:  # not left running for the next test, whatever the verdict
        orphan.kill()
    assert not alive, f"left behind: {[p.pid for p in alive]}"
    # the lock of the killed run is stale: taken over; committed chunks are kept
    manifest = run_unitcell_sweep(job_from_dict(JOB), out)
    assert manifest["status"] == {"reached": 4}
    curves = pd.read_parquet(out / "curves.parquet")
    assert curves.groupby("curve")["H"].first().tolist() == [3.0, 3.5, 4.0, 4.5]
