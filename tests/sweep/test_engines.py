"""Dask engine on a real LocalCluster of worker processes: same rows as the local engine, no
oversubscription, safe with threaded workers, and a worker killed mid-chunk loses nothing."""

from __future__ import annotations

import os
import signal
import threading
import time

import dask
import numba
import numpy as np
import pandas as pd
import pytest
from distributed import Client, LocalCluster
from model_helpers import other_set
from sweep_helpers import CrashingEvaluator, UnitConstantsEvaluator, make_job

from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.engines import DaskEngine, LocalEngine, make_engine
from dpfexplore.sweep.storage import store

# A sequential-states job; its N = 6 chunks of 300 designs take about 0.2 s on one core, long
# enough to kill a worker in the middle of one.
STATICS_JOB = {
    "job.samples_per_n": 600,
    "space.n_units": [5, 6],
    "compute.states": "sequential",
    "compute.min_eig": True,
}


def read_sorted(path, by):
    return store.read_results(path).sort_values(by).reset_index(drop=True)


@pytest.fixture(scope="module")
def local_reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "out"
    run_sweep(make_job(**STATICS_JOB), out, engine=LocalEngine(), chunk_size=600)
    return read_sorted(out, ["design_id", "requested"])


@pytest.fixture(scope="module")
def cluster():
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        yield cluster


def test_make_engine():
    assert isinstance(make_engine("local"), LocalEngine)
    engine = make_engine("dask", workers=2)
    assert isinstance(engine, DaskEngine) and engine.n_workers == 2
    with pytest.raises(ValueError, match="--scheduler"):
        make_engine("local", scheduler="tcp://x:1")
    with pytest.raises(ValueError, match="--engine"):
        make_engine("spark")


def test_dask_local_cluster_matches_local_engine(tmp_path, local_reference):
    # The engine starts (and stops) its own LocalCluster of 2 worker processes; a different
    # chunk size on top, to show independence of both.
    engine = DaskEngine(n_workers=2)
    summary = run_sweep(make_job(**STATICS_JOB), tmp_path / "out", engine=engine, chunk_size=100)
    assert summary.complete and summary.engine == "dask"
    assert {"compile_s", "cluster_start_s", "worker_warmup_s"} <= set(summary.timings)
    pd.testing.assert_frame_equal(
        read_sorted(tmp_path / "out", ["design_id", "requested"]), local_reference
    )
    # No oversubscription: 2 worker processes x Numba threads <= cores, one thread each.
    info = engine.worker_info
    assert len(info) == 2
    cores = os.cpu_count()
    assert sum(w["numba_threads"] for w in info.values()) <= max(cores, 2)
    for worker in info.values():
        assert worker["numba_max_threads"] == max(1, cores // 2)
        assert worker["threading_layer"] in {"tbb", "omp", "workqueue"}
    assert len({w["pid"] for w in info.values()}) == 2
    # the workers load the kernels from the cache the parent compiled into
    assert {w["cache_dir"] for w in info.values()} == {numba.config.CACHE_DIR}
    assert all(w["pid"] != os.getpid() for w in info.values())


def test_existing_scheduler_and_worker_count_invariance(tmp_path, cluster):
    spec = make_job(**{"job.samples_per_n": 200})
    one = tmp_path / "one"
    run_sweep(spec, one, engine=LocalEngine(), evaluator=UnitConstantsEvaluator(), chunk_size=200)
    two = tmp_path / "two"
    summary = run_sweep(
        spec,
        two,
        engine=DaskEngine(scheduler=cluster.scheduler_address),
        evaluator=UnitConstantsEvaluator(),
        chunk_size=9,
    )
    assert summary.complete and summary.chunks_computed == 46
    by = ["design_id", "unit"]
    pd.testing.assert_frame_equal(read_sorted(one, by), read_sorted(two, by))


def test_threaded_worker_runs_chunks_one_at_a_time(tmp_path, local_reference):
    # One worker process with two threads, and Numba's workqueue layer, which aborts the
    # process when two threads enter parallel kernels at once: the process lock of run_chunk
    # must serialise the chunks.
    env = {"NUMBA_THREADING_LAYER": "workqueue", "NUMBA_NUM_THREADS": "2"}
    with LocalCluster(
        n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None, env=env
    ) as threaded:
        engine = DaskEngine(scheduler=threaded.scheduler_address)
        summary = run_sweep(
            make_job(**STATICS_JOB), tmp_path / "out", engine=engine, chunk_size=150
        )
        (info,) = engine.worker_info.values()
    assert info["threading_layer"] == "workqueue"
    assert summary.complete and not summary.failures
    pd.testing.assert_frame_equal(
        read_sorted(tmp_path / "out", ["design_id", "requested"]), local_reference
    )


def _executing_chunks(dask_worker) -> list[str]:
    return [
        str(ts.key)
        for ts in dask_worker.state.executing
        if str(ts.key).startswith("dpfexplore-chunk")
    ]


def test_worker_killed_mid_chunk(tmp_path, local_reference, cluster):
    client = Client(cluster)
    try:
        pids = client.run(os.getpid)
        engine = DaskEngine(scheduler=cluster.scheduler_address)
        outcome = {}

        def sweep():
            try:
                outcome["summary"] = run_sweep(
                    make_job(**STATICS_JOB), tmp_path / "out", engine=engine, chunk_size=300
                )
            except BaseException as exc:  # reported by the assertion below
                outcome["error"] = exc

        thread = threading.Thread(target=sweep)
        thread.start()
        victim = None
        deadline = time.monotonic() + 120
        # Wait for an N = 6 chunk (the longest) to be executing on a worker, then kill that
        # worker's process at once.
        while victim is None and time.monotonic() < deadline and thread.is_alive():
            for address, keys in client.run(_executing_chunks).items():
                if any("-N06-" in key for key in keys):
                    victim = address
                    os.kill(pids[victim], signal.SIGKILL)
                    break
            else:
                time.sleep(0.01)
        assert victim is not None, "no chunk was seen running"
        thread.join(timeout=300)
        assert not thread.is_alive()
        assert "error" not in outcome, outcome.get("error")
        summary = outcome["summary"]
        assert summary.complete and not summary.failures
        # the nanny restarted the killed worker process
        client.wait_for_workers(2, timeout=60)
        assert pids[victim] not in set(client.run(os.getpid).values())
    finally:
        client.close()
    frame = read_sorted(tmp_path / "out", ["design_id", "requested"])
    assert not frame.duplicated(["design_id", "requested"]).any()
    pd.testing.assert_frame_equal(frame, local_reference)
    assert not list((tmp_path / "out").rglob("*.tmp"))


@pytest.mark.slow
def test_a_chunk_that_kills_every_worker_fails_alone(tmp_path):
    # The N = 3 chunk aborts whichever process runs it: after its attempts it is reported as
    # failed, the sweep ends (no hang, although the nannies restart workers again and again),
    # and a resume with a sound evaluator completes the dataset.
    spec = make_job()
    engine = DaskEngine(n_workers=2, no_workers_timeout=60)
    # Dask's scheduler gives up on the chunk at its first worker death (KilledWorker) instead
    # of its fourth: each of the engine's attempts still kills a worker and is resubmitted, with
    # 3 worker restarts in all instead of 12.
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        summary = run_sweep(
            spec, tmp_path / "out", engine=engine, evaluator=CrashingEvaluator(3), chunk_size=60
        )
    failed = {f.task.path for f in summary.failures}
    assert "N03/part-000000.parquet" in failed
    error = summary.failures[0].error
    assert "KilledWorker" in error or "no Dask worker" in error
    assert not summary.complete
    manifest = store.read_manifest(tmp_path / "out")
    assert set(manifest.chunks) == {"N02/part-000000.parquet"} - failed
    resumed = run_sweep(
        spec,
        tmp_path / "out",
        resume=True,
        engine=LocalEngine(),
        evaluator=UnitConstantsEvaluator(),
    )
    assert resumed.complete
    reference = tmp_path / "reference"
    run_sweep(spec, reference, evaluator=UnitConstantsEvaluator(), chunk_size=60)
    by = ["design_id", "unit"]
    pd.testing.assert_frame_equal(read_sorted(tmp_path / "out", by), read_sorted(reference, by))


def test_dask_workers_run_on_the_jobs_constants_set(tmp_path, cluster):
    """The job's constants set travels to the workers with the job (issue 20)."""
    path = other_set().save(tmp_path / "other.json")
    spec = make_job(**{"job.samples_per_n": 40, "job.constants": str(path)})
    assert spec.constants == other_set()
    local, remote, paper = tmp_path / "local", tmp_path / "remote", tmp_path / "paper"
    run_sweep(spec, local, engine=LocalEngine(), chunk_size=40)
    run_sweep(spec, remote, engine=DaskEngine(scheduler=cluster.scheduler_address), chunk_size=7)
    by = ["design_id", "requested"]
    pd.testing.assert_frame_equal(read_sorted(local, by), read_sorted(remote, by))
    run_sweep(make_job(**{"job.samples_per_n": 40}), paper, engine=LocalEngine(), chunk_size=40)
    # the same designs, other constants: other tips
    a, b = read_sorted(local, by), read_sorted(paper, by)
    assert (a["H_1"] == b["H_1"]).all() and not np.allclose(a["tip_x"], b["tip_x"])
