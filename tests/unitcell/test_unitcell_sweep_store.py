"""``unitcell sweep`` on the sweeps' storage: one writer, chunks checked on resume and on merge,
interrupted runs resumed, failed chunks retried, directories of the older layout refused."""

from __future__ import annotations

import json
import logging
import time

import pandas as pd
import pytest
from sweep_helpers import spawned_workers

from dpfexplore.cli import main
from dpfexplore.io.commits import StoreError
from dpfexplore.io.lock import LOCK_NAME, LockHeld, sweep_lock
from dpfexplore.unitcell import sweep_chunks
from dpfexplore.unitcell.sweep import SweepIncomplete, job_from_dict, run_unitcell_sweep

# Four geometries, one per chunk; the last one is invalid (t > r_b): a row, not a crash.
JOB = {
    "grid": {"H": [3.0, 3.5, 4.0], "t": [0.8], "r_b": 5.0},
    "options": {"n_elements": 32, "chunk": 1},
}
GRID_WITH_INVALID = {**JOB, "grid": {"H": [3.0, 4.0], "t": [0.8, 6.0], "r_b": 5.0}}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "sw"
    run_unitcell_sweep(job_from_dict(JOB), out)
    return tables(out)


def tables(out):
    curves = pd.read_parquet(out / "curves.parquet")
    designs = pd.read_parquet(out / "designs.parquet").drop(columns="seconds")
    return curves, designs


def assert_same(out, reference):
    curves, designs = tables(out)
    pd.testing.assert_frame_equal(curves, reference[0])
    pd.testing.assert_frame_equal(designs, reference[1])


def chunk_manifest(out):
    return json.loads((out / "chunks" / "_manifest.json").read_text())


def test_chunks_are_committed_with_their_checksums(tmp_path, reference):
    out = tmp_path / "sw"
    manifest = run_unitcell_sweep(job_from_dict(JOB), out)
    assert manifest["chunks"] == 3
    committed = chunk_manifest(out)
    assert committed["complete"] and len(committed["chunks"]) == 3
    for chunk in committed["chunks"].values():
        for record in (chunk["designs"], chunk["curves"]):
            path = out / "chunks" / record["path"]
            assert path.stat().st_size == record["bytes"] and len(record["sha256"]) == 64
    assert not (out / LOCK_NAME).exists()
    assert not list(out.rglob("*.tmp"))
    assert_same(out, reference)


def test_a_second_writer_is_refused_naming_the_holder(tmp_path, capsys):
    out = tmp_path / "sw"
    with sweep_lock(out):
        with pytest.raises(LockHeld, match="another sweep is using this directory: pid"):
            run_unitcell_sweep(job_from_dict(JOB), out)
        job = tmp_path / "job.toml"
        job.write_text("[grid]\nH = [3.0]\nt = [0.8]\n[options]\nn_elements = 32\n")
        assert main(["unitcell", "sweep", str(job), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert "another sweep is using this directory" in err and len(err.splitlines()) == 1
    assert not (out / "chunks").exists()  # the refused runs wrote nothing


@pytest.mark.parametrize("damage", ["delete", "edit"])
def test_a_chunk_deleted_or_edited_is_recomputed_on_resume(tmp_path, reference, caplog, damage):
    out = tmp_path / "sw"
    job = job_from_dict(JOB)
    run_unitcell_sweep(job, out)
    target = out / "chunks" / "part-00001.curves.parquet"
    if damage == "delete":
        target.unlink()
    else:  # a valid Parquet file with other numbers: only the checksum tells
        frame = pd.read_parquet(target)
        frame["force"] *= 1.5
        frame.to_parquet(target, index=False)
    seen = []
    with caplog.at_level(logging.WARNING):
        run_unitcell_sweep(job, out, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(3, 3)]  # only the damaged chunk was traced again
    assert "recomputing chunk part-00001" in caplog.text
    assert_same(out, reference)


def test_a_chunk_changed_after_the_check_is_refused_at_the_merge(tmp_path):
    out = tmp_path / "sw"
    run_unitcell_sweep(job_from_dict(JOB), out)
    manifest = sweep_chunks.read_manifest(out / "chunks")
    path = out / "chunks" / "part-00002.designs.parquet"
    path.write_bytes(path.read_bytes()[:-1] + b"\0")  # same size, other bytes
    with pytest.raises(StoreError, match=r"part-00002\.designs\.parquet: SHA-256 differs"):
        sweep_chunks.merge_chunks(out / "chunks", manifest)


@pytest.mark.parametrize("workers", [1, 2])
def test_an_interrupted_sweep_keeps_its_chunks_and_resumes(tmp_path, reference, workers):
    out = tmp_path / "sw"
    job = job_from_dict(JOB)

    interrupted: list[float] = []

    def interrupt(done, total):
        interrupted.append(time.perf_counter())
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_unitcell_sweep(job, out, workers=workers, progress=interrupt)
    # stopped at once, the chunks not yet traced abandoned (not computed and discarded: ~1 s
    # quiet, with the worker processes ended; the bound leaves room for a loaded machine)
    assert time.perf_counter() - interrupted[0] < 5.0
    assert len(chunk_manifest(out)["chunks"]) == 1
    assert not (out / LOCK_NAME).exists() and not (out / "manifest.json").exists()
    assert not spawned_workers()
    seen = []
    run_unitcell_sweep(job, out, workers=workers, progress=lambda d, t: seen.append(d))
    assert sorted(seen) == [2, 3]  # the committed chunk was kept
    assert_same(out, reference)


def test_a_chunk_that_cannot_be_written_fails_alone_and_a_rerun_completes(
    tmp_path, reference, monkeypatch
):
    out = tmp_path / "sw"
    job = job_from_dict(JOB)
    write = sweep_chunks.UnitCellWork.write

    def full_disk_on_chunk_1(self, task, result):
        if task.index == 1:
            raise OSError(28, "No space left on device")
        return write(self, task, result)

    monkeypatch.setattr(sweep_chunks.UnitCellWork, "write", full_disk_on_chunk_1)
    with pytest.raises(SweepIncomplete, match=r"1 chunk.*part-00001.*No space left"):
        run_unitcell_sweep(job, out)
    assert set(chunk_manifest(out)["chunks"]) == {"part-00000", "part-00002"}
    monkeypatch.undo()
    seen = []
    run_unitcell_sweep(job, out, progress=lambda d, t: seen.append(d))
    assert seen == [3]
    assert_same(out, reference)


def test_a_damaged_job_file_is_recovered(tmp_path):
    out = tmp_path / "sw"
    out.mkdir()
    (out / "job.json").write_text("")  # what a full disk left behind
    job = job_from_dict(GRID_WITH_INVALID)
    manifest = run_unitcell_sweep(job, out)
    assert manifest["status"] == {"reached": 2, "invalid": 2}
    assert json.loads((out / "job.json").read_text())["fingerprint"] == job.fingerprint
    (out / "job.json").write_text("[1, 2]")  # not an object: the chunk manifest says whose it is
    assert run_unitcell_sweep(job, out) == manifest


def test_a_directory_of_the_older_layout_is_refused_in_one_line(tmp_path, capsys):
    out = tmp_path / "sw"
    (out / "chunks").mkdir(parents=True)
    job = job_from_dict(JOB)
    (out / "job.json").write_text(json.dumps({"fingerprint": job.fingerprint, "job": JOB}))
    pd.DataFrame({"design": [0]}).to_parquet(out / "chunks" / "designs-00000.parquet")
    with pytest.raises(ValueError, match=r"older unit-cell sweep.*give a new directory"):
        run_unitcell_sweep(job, out)
    toml = tmp_path / "job.toml"
    toml.write_text(
        "[grid]\nH = [3.0, 3.5, 4.0]\nt = [0.8]\n[options]\nn_elements = 32\nchunk = 1\n"
    )
    assert main(["unitcell", "sweep", str(toml), "--out", str(out)]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert sorted(p.name for p in (out / "chunks").iterdir()) == ["designs-00000.parquet"]


def test_a_finger_sweep_dataset_is_not_a_unit_cell_directory(tmp_path):
    out = tmp_path / "dataset"
    out.mkdir()
    (out / "_manifest.json").write_text("{}")
    with pytest.raises(ValueError, match="finger sweep"):
        run_unitcell_sweep(job_from_dict(JOB), out)
    assert sorted(p.name for p in out.iterdir()) == ["_manifest.json"]
