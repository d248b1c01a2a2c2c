"""Sweeps on the local engine: rows per design, chunk invariance, resume, refusals, statuses."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sweep_helpers import UnitConstantsEvaluator, make_job

from dpfexplore.model import status as st
from dpfexplore.model.design import DesignBatch
from dpfexplore.solvers.statics import solve_batch
from dpfexplore.sweep import chunks
from dpfexplore.sweep import driver as sweep
from dpfexplore.sweep.chunks import default_chunk_size, plan_chunks
from dpfexplore.sweep.driver import check_output, run_sweep
from dpfexplore.sweep.evaluation import StaticsEvaluator
from dpfexplore.sweep.sampling import sample_designs
from dpfexplore.sweep.storage import store
from dpfexplore.sweep.storage.store import StoreError

SORT = ["design_id", "unit"]


def read_sorted(path, by=SORT):
    return store.read_results(path).sort_values(by).reset_index(drop=True)


def run(spec, out, **kwargs):
    kwargs.setdefault("evaluator", UnitConstantsEvaluator())
    return run_sweep(spec, out, **kwargs)


def test_plan_chunks_cover_every_design_once():
    spec = make_job(**{"job.samples_per_n": 25})
    tasks = plan_chunks(spec, {2: 10, 3: 7})
    for n in (2, 3):
        covered = np.concatenate([np.arange(t.start, t.stop) for t in tasks if t.n_units == n])
        np.testing.assert_array_equal(covered, np.arange(25))
    assert len({t.path for t in tasks}) == len(tasks)


def test_default_chunk_size_bounds_rows():
    spec = make_job(**{"compute.states": "all"})
    assert default_chunk_size(spec.compute, 8) * 2**8 <= chunks.TARGET_CHUNK_ROWS
    assert default_chunk_size(make_job().compute, 2) == chunks.MAX_CHUNK_DESIGNS


def test_sweep_writes_every_design(tmp_path):
    spec = make_job()
    summary = run(spec, tmp_path / "out", chunk_size=16)
    assert summary.complete and not summary.failures
    assert summary.chunks_total == summary.chunks_computed == 8
    frame = read_sorted(tmp_path / "out")
    designs = frame.groupby("design_id").size()
    assert len(designs) == spec.n_designs
    np.testing.assert_array_equal(designs.index, np.arange(spec.n_designs))
    # one row per unit of each design: 2 or 3
    np.testing.assert_array_equal(designs.to_numpy(), np.repeat([2, 3], 60))
    assert summary.rows == len(frame) == 5 * 60
    assert summary.statuses == {"ok": 300}
    manifest = store.read_manifest(tmp_path / "out")
    assert manifest.complete and len(manifest.chunks) == 8
    # the stored inputs are the sampled designs
    batch = sample_designs(spec, 3, 0, 60)
    rows = frame[(frame.n_units == 3) & (frame.unit == 1)].sort_values("sample")
    np.testing.assert_array_equal(rows["H_2"], batch.H[:, 1])
    np.testing.assert_array_equal(rows["t_lim"], batch.t_lim)


def test_chunk_size_invariance(tmp_path):
    spec = make_job()
    run(spec, tmp_path / "a", chunk_size=7)
    run(spec, tmp_path / "b", chunk_size=60)
    pd.testing.assert_frame_equal(read_sorted(tmp_path / "a"), read_sorted(tmp_path / "b"))


def test_refusals_write_nothing(tmp_path):
    spec = make_job()
    out = tmp_path / "out"
    run(spec, out, chunk_size=30)
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*")}
    other = make_job(**{"job.seed": 8})
    with pytest.raises(StoreError, match=r"another job's data \(job.seed differs"):
        run(other, out)
    rerun = run(spec, out)  # complete: a rerun computes nothing and reports it (issue 11)
    assert rerun.complete and rerun.designs_computed == 0 and rerun.chunks_reused == 4
    with pytest.raises(StoreError, match="chunk sizes"):
        run(spec, out, resume=True, chunk_size=10)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(StoreError, match="not a sweep directory"):
        run(spec, foreign)
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*")} == before
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]


def test_resume_refuses_another_model_version(tmp_path, monkeypatch):
    spec = make_job()
    run(spec, tmp_path / "out", chunk_size=30)
    monkeypatch.setattr(sweep, "MODEL_VERSION", "dpf-lattice-999")
    with pytest.raises(StoreError, match="model version"):
        run(spec, tmp_path / "out", resume=True)


def test_resume_recomputes_only_missing_or_damaged_chunks(tmp_path):
    spec = make_job()
    reference = tmp_path / "reference"
    run(spec, reference, chunk_size=10)
    out = tmp_path / "out"
    run(spec, out, chunk_size=10)
    manifest = store.read_manifest(out)
    lost = "N02/part-000001.parquet"  # committed, then deleted
    damaged = "N03/part-000004.parquet"  # committed, then corrupted
    uncommitted = "N03/part-000000.parquet"  # renamed into place, manifest never updated
    (out / lost).unlink()
    data = bytearray((out / damaged).read_bytes())
    data[100] ^= 0xFF
    (out / damaged).write_bytes(bytes(data))
    del manifest.chunks[uncommitted]
    manifest.complete = False
    store.write_manifest(out, manifest)
    (out / "N02" / ".part-000003.parquet.99-dead.tmp").write_bytes(b"partial")

    prepared = check_output(spec, out, resume=True)
    assert sorted(t.path for t in prepared.pending) == sorted([lost, damaged, uncommitted])
    summary = run(spec, out, resume=True)
    assert summary.chunks_computed == 3 and summary.chunks_reused == 9
    assert summary.complete
    assert not list(out.rglob("*.tmp"))
    pd.testing.assert_frame_equal(read_sorted(out), read_sorted(reference))
    # nothing left to do on a complete directory
    again = run(spec, out, resume=True)
    assert again.chunks_computed == 0 and again.complete


def test_resume_of_an_empty_or_absent_directory_starts_fresh(tmp_path):
    spec = make_job(**{"job.samples_per_n": 5})
    summary = run(spec, tmp_path / "new", resume=True)
    assert summary.complete and summary.rows == 25


def test_failed_chunk_is_reported_and_resumed(tmp_path):
    class Flaky(UnitConstantsEvaluator):
        def __call__(self, batch):
            if batch.n_units[0] == 3:
                raise RuntimeError("boom")
            return super().__call__(batch)

    spec = make_job()
    summary = run(spec, tmp_path / "out", chunk_size=30, evaluator=Flaky())
    assert not summary.complete
    assert [f.task.path for f in summary.failures] == [
        "N03/part-000000.parquet",
        "N03/part-000001.parquet",
    ]
    assert "boom" in summary.failures[0].error
    assert len(read_sorted(tmp_path / "out")) == 2 * 60  # the N = 2 chunks are committed
    resumed = run(spec, tmp_path / "out", resume=True)
    assert resumed.complete and resumed.chunks_computed == 2


# ----------------------------------------------------------------------------- the real solver


def test_statics_sweep_matches_solve_batch(tmp_path):
    spec = make_job(
        **{"job.samples_per_n": 30, "compute.states": "sequential", "compute.min_eig": True}
    )
    summary = run_sweep(spec, tmp_path / "out", chunk_size=12)
    assert summary.complete
    frame = store.read_results(tmp_path / "out")
    assert {"stiffness", "min_eig", "requested_bits", "found_bits"} <= set(frame.columns)
    assert set(frame.groupby("design_id").size()) == {3, 4}  # N + 1 sequential states
    for n in (2, 3):
        direct = solve_batch(sample_designs(spec, n, 0, 30), "sequential")
        rows = frame[frame.n_units == n]
        np.testing.assert_array_equal(rows["requested"], direct["requested"])
        np.testing.assert_array_equal(rows["status"], direct["status"])
        for name in ("tip_x", "tip_y", "curvature", "stiffness", "min_eig", "energy"):
            np.testing.assert_array_equal(rows[name], direct[name])
    bits = frame.apply(lambda r: format(r.requested, f"0{r.n_units}b"), axis=1)
    assert (frame["requested_bits"].astype(str) == bits).all()
    assert set(frame["status_label"].astype(str)) <= {s.label for s in st.Status}


def test_only_requested_outputs_are_stored(tmp_path):
    spec = make_job(**{"job.samples_per_n": 4, "compute.stiffness": False})
    run_sweep(spec, tmp_path / "out")
    names = store.read_schema(tmp_path / "out").names
    assert "stiffness" not in names and "min_eig" not in names
    assert not any(name.startswith("reset_time") for name in names)


def test_invalid_designs_keep_their_rows(tmp_path):
    # Thick, shallow domes leave the closed forms' domain (k_b <= 0 or alpha outside (0, 1)).
    spec = make_job(
        **{
            "job.samples_per_n": 40,
            "space.variables.H": {"min": 0.6, "max": 4.0},
            "space.variables.t": {"min": 0.5, "max": 1.6},
            "space.n_units": [3],
        }
    )
    summary = run_sweep(spec, tmp_path / "out", chunk_size=16)
    frame = store.read_results(tmp_path / "out")
    assert sorted(frame["design_id"]) == list(range(40))  # one row per design, valid or not
    invalid = frame[frame.status == st.INVALID_CONSTANTS]
    assert 0 < len(invalid) < 40
    assert (invalid["status_label"] == "invalid_constants").all()
    assert invalid["problem"].str.contains("closed forms").all()
    assert invalid["tip_x"].isna().all() and (invalid["requested"] == -1).all()
    assert frame.loc[frame.status == st.OK, "problem"].isna().all()
    assert summary.statuses["invalid_constants"] == len(invalid)


def test_invalid_input_rows_through_the_evaluator():
    # A design no job can sample (a NaN height) still gets its row and status.
    spec = make_job()
    batch = sample_designs(spec, 2, 0, 3)
    H = batch.H.copy()
    H[1, 0] = np.nan
    bad = DesignBatch(**{**{n: getattr(batch, n) for n in batch.ARRAY_FIELDS}, "H": H})
    rows = StaticsEvaluator(spec.compute)(bad)
    np.testing.assert_array_equal(rows["design_index"], [0, 1, 2])
    assert rows["status"][1] == st.INVALID_INPUT and rows["requested"][1] == -1


def test_reset_times_for_every_valid_design(tmp_path):
    from dpfexplore.solvers.dynamics.simulate import PressureProfile, reset_times_batch

    load = {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0}
    spec = make_job(
        **{
            "job.samples_per_n": 40,
            "space.n_units": [3],
            "compute.reset_times": load,
            "compute.stiffness": False,
            "compute.states": "sequential",
        }
    )
    run_sweep(spec, tmp_path / "out", chunk_size=16)
    frame = store.read_results(tmp_path / "out")
    designs = frame.drop_duplicates("design_id").sort_values("sample").reset_index(drop=True)
    batch = sample_designs(spec, 3, 0, 40)
    assert (batch.status() == st.OK).all()
    direct = reset_times_batch(batch, PressureProfile(P0=0.7, tau=(0.0, 1.0, 5.0, 5.1)), t_end=15.0)
    np.testing.assert_array_equal(designs["dyn_status"], direct["status"])
    np.testing.assert_array_equal(designs["final_state"], direct["final_state"])
    for k in range(1, 4):
        np.testing.assert_array_equal(designs[f"reset_time_{k}"], direct["reset_time"][:, k - 1])
        np.testing.assert_array_equal(designs[f"unit_class_{k}"], direct["unit_class"][:, k - 1])
    # some designs reset and some hold: both kinds of row are in the sample
    resets = np.isfinite(direct["reset_time"][:, :3]).any(axis=1)
    assert 0 < resets.sum() < 40
    # per-design values are repeated on every state row of the design
    assert len(frame) > len(designs)
    per_design = frame.groupby("design_id")["reset_time_2"].nunique(dropna=False)
    assert (per_design == 1).all()
