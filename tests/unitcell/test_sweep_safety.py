"""``unitcell sweep`` and ``unitcell curve`` under hostile conditions: sizes refused before any
allocation, a full disk at every point of a run, damaged job and manifest files, SIGTERM, a Dask
cluster without workers. Each case ends in one line (or the unmutated answer), never a traceback,
and leaves no partial file behind."""

from __future__ import annotations

import errno
import json
import logging
import os
import shutil
import signal
import time

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dpfexplore.cli import main
from dpfexplore.io.lock import LOCK_NAME
from dpfexplore.io.toml_fields import FieldError
from dpfexplore.unitcell import unit_cell_curve
from dpfexplore.unitcell.geometry import MAX_PATH_BYTES, check_path_size, path_bytes
from dpfexplore.unitcell.sweep import (
    MAX_CHUNKS,
    SweepIncomplete,
    SweepInterrupted,
    job_from_dict,
    run_unitcell_sweep,
)

# Three geometries, one per chunk, at the coarse mesh of the other sweep tests (~0.1 s each).
JOB = {"grid": {"H": [3.0, 3.5, 4.0], "t": [0.8]}, "options": {"n_elements": 32, "chunk": 1}}
JOB_TOML = "[grid]\nH = [3.0, 3.5, 4.0]\nt = [0.8]\n[options]\nn_elements = 32\nchunk = 1\n"


def tables(out):
    curves = pd.read_parquet(out / "curves.parquet")
    designs = pd.read_parquet(out / "designs.parquet").drop(columns="seconds")
    return curves, designs


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    """A complete sweep directory of :data:`JOB` and its tables."""
    out = tmp_path_factory.mktemp("done") / "sw"
    run_unitcell_sweep(job_from_dict(JOB), out)
    return out, tables(out)


def assert_same(out, reference):
    curves, designs = tables(out)
    pd.testing.assert_frame_equal(curves, reference[0])
    pd.testing.assert_frame_equal(designs, reference[1])


def leftovers(out):
    """Temporary files and the lock: what a finished or refused run must not leave."""
    return sorted(p.name for p in out.rglob("*") if p.name.endswith(".tmp") or p.name == LOCK_NAME)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# ---- sizes estimated and refused before allocation ---------------------------------------------


def test_a_grid_of_300_to_the_4th_is_refused_before_it_is_built(tmp_path, capsys):
    values = [round(3.0 + 0.001 * i, 3) for i in range(300)]
    source = {"grid": {"H": values, "t": values, "r_b": values, "E": values}}
    started = time.perf_counter()
    with pytest.raises(FieldError, match=r"grid \(300 x 300 x 300 x 300 x 1\): 8100000000 geo"):
        job_from_dict(source)
    assert time.perf_counter() - started < 1.0  # counted, not built (it took 3.5 GB)
    job = tmp_path / "big.toml"
    job.write_text("[grid]\n" + "".join(f"{k} = {values}\n" for k in ("H", "t", "r_b", "E")))
    assert main(["unitcell", "sweep", str(job), "--out", str(tmp_path / "sw")]) == 2
    assert "more than the 1000000 a sweep plans" in one_line(capsys.readouterr().err)
    assert not (tmp_path / "sw").exists()


def test_too_many_chunks_are_refused_with_the_chunk_size_that_fits():
    n = MAX_CHUNKS + 1
    source = {"lhs": {"n": n, "H": [3.0, 5.0], "t": [0.5, 1.0]}, "options": {"chunk": 1}}
    with pytest.raises(FieldError, match=rf"{n} chunks, more .*give options.chunk >= 2$"):
        job_from_dict(source)
    source["options"]["chunk"] = 2
    assert len(job_from_dict(source).geometries) == n


def test_path_bytes_is_what_the_kernel_allocates():
    from dpfexplore._kernels.shell import path as shell_path
    from dpfexplore._kernels.shell.records import PathControls
    from dpfexplore.unitcell.geometry import reference_unknowns, shell

    geom = shell(3.0, 0.8, 5.0, 26.0, 0.35, 16)
    controls = PathControls(0.01, 0.04, 1e-10, 7, 1e-9, 1e-10)
    _, _, points = shell_path.follow(geom, reference_unknowns(geom), 1.0, controls, 1.0, False)
    assert sum(a.nbytes for a in points) == path_bytes(16, 7)


#: The most steps a path of the default 128 elements may take (2 GiB of arrays).
MOST_STEPS = MAX_PATH_BYTES // path_bytes(128, 0) - 1


@pytest.mark.parametrize("steps", [100_000_000, MOST_STEPS + 1])
def test_max_steps_past_the_memory_budget_is_refused_before_allocation(capsys, steps):
    argv = ["unitcell", "curve", "--H", "3", "--t", "0.8", "--max-steps", str(steps)]
    started = time.perf_counter()
    assert main(argv) == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"dpfexplore unitcell: error: --max-steps {steps}: the path's arrays")
    assert line.endswith(f"more than the 2.15 GB allowed; give at most {MOST_STEPS}")
    assert MOST_STEPS == 521232
    check_path_size(128, MOST_STEPS)  # the largest allowed passes
    assert time.perf_counter() - started < 1.0
    with pytest.raises(FieldError, match=r"options.max_steps = 10000000: .* at 5000 elements"):
        job_from_dict({**JOB, "options": {"max_steps": 10_000_000, "n_elements": 5000}})


# ---- what a run says about itself ----------------------------------------------------------


def test_max_steps_5_says_the_step_budget_ran_out(capsys):
    argv = ["unitcell", "curve", "--H", "3", "--t", "0.8", "--elements", "32", "--max-steps", "5"]
    assert main(argv) == 0
    status = capsys.readouterr().out.splitlines()[1]
    assert status.startswith("path: partial (the path stopped before the requested travel (max")
    assert "max_steps steps taken" in status and "corrector" not in status


def test_a_geometry_with_no_path_is_a_status_and_one_line(tmp_path, capsys):
    run = unit_cell_curve(3.0, 0.8, 1e5, n_elements=32)
    assert (run.status, run.n_steps, run.tip_dis) == ("no_path", 0, None)
    assert run.to_frame().empty and run.folds.size == 0
    table, figure = tmp_path / "c.csv", tmp_path / "c.png"
    argv = ["unitcell", "curve", "--H", "3", "--t", "0.8", "--r-b", "1e5", "--elements", "32"]
    assert main([*argv, "--out", str(table), "--plot", str(figure)]) == 1
    captured = capsys.readouterr()
    assert "no point of the path" in one_line(captured.err)
    assert "path: no_path" in captured.out
    assert not table.exists() and not figure.exists()
    # in a sweep, the geometry is a row with its status
    out = tmp_path / "sw"
    run_unitcell_sweep(job_from_dict({**JOB, "grid": {"H": [3.0], "t": [0.8], "r_b": 1e5}}), out)
    designs = pd.read_parquet(out / "designs.parquet")
    assert designs["status"].tolist() == ["no_path"]


def test_a_stiff_material_traces_the_same_path_without_warnings():
    # pytest turns warnings into errors: the overflow of a force product was a RuntimeWarning
    soft = unit_cell_curve(3.0, 0.8, E=26.0, n_elements=32)
    stiff = unit_cell_curve(3.0, 0.8, E=1e300, n_elements=32)
    assert stiff.status == soft.status == "reached" and stiff.n_steps == soft.n_steps
    np.testing.assert_allclose(stiff.displacement, soft.displacement, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(stiff.force / 1e300, soft.force / 26.0, rtol=1e-6, atol=1e-12)
    assert stiff.tip_dis == pytest.approx(soft.tip_dis, rel=1e-9)


@settings(max_examples=8)
@given(
    H=st.sampled_from([1e-6, 3.0, 1e4]),
    t=st.sampled_from([1e-7, 0.8]),
    r_b=st.sampled_from([5.0, 1e5]),
    e_exponent=st.integers(-300, 300),
)
def test_any_scale_is_a_run_or_a_one_line_refusal(H, t, r_b, e_exponent):
    # the class of r_b = 1e5 (IndexError) and E = 1e300 (RuntimeWarning): extremes of every input
    try:
        run = unit_cell_curve(H, t, r_b, E=10.0**e_exponent, n_elements=16, max_steps=400)
    except ValueError as exc:  # refused: one line naming a parameter
        assert "\n" not in str(exc) and str(exc).split("=")[0] in {"H", "t", "r_b", "E"}
        return
    assert run.status in {
        "reached",
        "partial",
        "max_steps",
        "backward",
        "step_too_small",
        "no_path",
    }
    assert (run.n_steps == 0) == (run.status == "no_path")
    assert len(run.to_frame()) == run.n_steps


# ---- a full disk at every point of a run --------------------------------------------------------


class FullDisk:
    """``os.fsync`` of files under ``root`` fails with ENOSPC after ``room`` successful ones.

    Every write of the tool goes through a temporary file fsynced before its rename
    (``io.files.atomic_writer``) or, for the lock, a file fsynced after its write: failing the
    fsync is a disk that fills during that write. ``name``: only files whose name holds it.
    """

    def __init__(self, monkeypatch, root, room: int, name: str = "") -> None:
        self.root, self.room, self.name, self.real = str(root), room, name, os.fsync
        monkeypatch.setattr(os, "fsync", self)

    def __call__(self, fd: int) -> None:
        path = os.readlink(f"/proc/self/fd/{fd}")
        ours = path.startswith(self.root) and self.name in os.path.basename(path)
        if ours and os.path.isfile(path):
            if self.room <= 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            self.room -= 1
        self.real(fd)


@pytest.mark.parametrize("room", [0, 1, 2, 3, 5, 8])
def test_a_full_disk_at_any_write_leaves_a_directory_the_next_run_completes(
    tmp_path, monkeypatch, capsys, done, room
):
    job, out = tmp_path / "job.toml", tmp_path / "sw"
    job.write_text(JOB_TOML)
    disk = FullDisk(monkeypatch, out, room)
    code = main(["unitcell", "sweep", str(job), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "Traceback" not in err
    # progress lines and the log lines of failed chunks aside, one line says what happened
    said = [x for x in err.splitlines() if x.startswith("dpfexplore unitcell sweep: ")]
    said = [x for x in said if not x.startswith("dpfexplore unitcell sweep: chunk ")]
    assert len(said) == 1 and "No space left on device" in said[0]
    # nothing half-written: no lock, no temporary file, no empty or partial job.json
    assert leftovers(tmp_path) == []
    if (out / "job.json").exists():
        assert json.loads((out / "job.json").read_text())["fingerprint"]
    disk.room = 1 << 30  # room again
    assert main(["unitcell", "sweep", str(job), "--out", str(out)]) == 0
    assert_same(out, done[1])
    assert leftovers(tmp_path) == []


def test_a_full_disk_during_a_chunk_write_fails_that_chunk_in_one_line(tmp_path, monkeypatch):
    out = tmp_path / "sw"
    FullDisk(monkeypatch, out, 0, name="part-00001")
    with pytest.raises(SweepIncomplete, match=r"1 chunk.*part-00001.*No space left on device"):
        run_unitcell_sweep(job_from_dict(JOB), out)
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize(
    "option, name", [("--out", "c.csv"), ("--out", "c.parquet"), ("--plot", "c.png")]
)
def test_curve_files_on_a_full_disk_are_absent_or_untouched(
    tmp_path, monkeypatch, capsys, option, name
):
    target = tmp_path / name
    argv = ["unitcell", "curve", "--H", "3", "--t", "0.8", "--elements", "32", option, str(target)]
    FullDisk(monkeypatch, tmp_path, 0)
    assert main(argv) == 1
    line = one_line(capsys.readouterr().err)
    assert line == f"dpfexplore unitcell: cannot write {target}: No space left on device"
    assert not target.exists() and leftovers(tmp_path) == []
    if option == "--out":  # an existing file is left as it was (a figure the same way)
        target.write_bytes(b"before")
        assert main([*argv, "--force"]) == 1  # replacing it, as asked, fails whole
        assert target.read_bytes() == b"before" and leftovers(tmp_path) == []
        capsys.readouterr()


# ---- damaged files in the directory -----------------------------------------------------------


def test_temporary_files_do_not_survive_a_later_run(tmp_path, done):
    out = tmp_path / "sw"
    shutil.copytree(done[0], out)
    for place in (out, out / "chunks"):
        (place / ".job.json.123-deadbeef.tmp").write_bytes(b"half")
    (out / "chunks" / ".part-00001.curves.parquet.9-cafe.tmp").write_bytes(b"half")
    run_unitcell_sweep(job_from_dict(JOB), out)
    assert leftovers(out) == []
    assert_same(out, done[1])


def test_a_fractional_chunk_is_refused_and_the_corrected_job_runs_there(tmp_path, capsys, done):
    job, out = tmp_path / "job.toml", tmp_path / "sw"
    job.write_text(JOB_TOML.replace("chunk = 1", "chunk = 0.5"))
    assert main(["unitcell", "sweep", str(job), "--out", str(out)]) == 2
    assert "options.chunk = 0.5: must be an integer" in one_line(capsys.readouterr().err)
    assert not out.exists()
    job.write_text(JOB_TOML)
    assert main(["unitcell", "sweep", str(job), "--out", str(out)]) == 0
    assert_same(out, done[1])


def _leaves(value, path=()):
    """Paths to every scalar of a JSON document."""
    if isinstance(value, dict):
        return [p for key, item in value.items() for p in _leaves(item, (*path, key))]
    if isinstance(value, list):
        return [p for k, item in enumerate(value) for p in _leaves(item, (*path, k))]
    return [path]


def _flip(data: bytes, draw) -> bytes:
    """Bytes truncated, flipped, inserted or deleted at a random place."""
    kind = draw(st.sampled_from(["truncate", "flip", "insert", "delete"]))
    at = draw(st.integers(0, len(data) - 1))
    if kind == "truncate":
        return data[:at]
    if kind == "flip":
        return data[:at] + bytes([data[at] ^ draw(st.integers(1, 255))]) + data[at + 1 :]
    if kind == "insert":
        return data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at:]
    return data[:at] + data[at + draw(st.integers(1, 16)) :]


def _mutate(data: bytes, draw) -> bytes:
    """One random edit of a JSON file: a value replaced (two times in three), or :func:`_flip`."""
    if draw(st.integers(0, 2)) == 0:
        return _flip(data, draw)
    document = json.loads(data)
    *parents, last = draw(st.sampled_from(_leaves(document)))
    place = document
    for key in parents:
        place = place[key]
    place[last] = draw(
        st.one_of(
            st.none(),
            st.booleans(),
            st.integers(-2, 10**6),
            st.floats(allow_nan=False, allow_infinity=False),
            st.text(max_size=6),
            st.sampled_from(["part-00002", "part-00000.designs.parquet", "0" * 64]),
        )
    )
    return json.dumps(document).encode()


@settings(max_examples=20)
@given(data=st.data(), name=st.sampled_from(["job.json", "chunks/_manifest.json"]))
def test_a_mutated_job_or_manifest_file_is_refused_naming_it_or_gives_the_same_tables(
    tmp_path_factory, done, data, name
):
    out = tmp_path_factory.mktemp("mutated") / "sw"
    shutil.copytree(done[0], out)
    (out / "manifest.json").unlink()
    target = out / name
    target.write_bytes(_mutate(target.read_bytes(), data.draw))
    try:
        run_unitcell_sweep(job_from_dict(JOB), out)
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message and str(target) in message
        assert name == "chunks/_manifest.json"  # job.json is only a label: always recovered
        return
    assert_same(out, done[1])
    assert json.loads((out / "job.json").read_text())["job"] == JOB


@pytest.mark.parametrize(
    "edit",
    [
        {"index": 2},
        {"start": 0, "stop": 1},
        {"designs": "part-00000.designs.parquet"},
    ],
)
def test_a_chunk_record_moved_to_another_chunk_is_recomputed(tmp_path, done, caplog, edit):
    out = tmp_path / "sw"
    shutil.copytree(done[0], out)
    path = out / "chunks" / "_manifest.json"
    manifest = json.loads(path.read_text())
    record = manifest["chunks"]["part-00001"]
    for key, value in edit.items():
        if key == "designs":  # the file and checksum of chunk 0, under chunk 1's name
            record["designs"] = manifest["chunks"]["part-00000"]["designs"]
        else:
            record[key] = value
    path.write_text(json.dumps(manifest))
    with caplog.at_level(logging.WARNING):
        run_unitcell_sweep(job_from_dict(JOB), out)
    assert "recomputing chunk part-00001" in caplog.text
    assert_same(out, done[1])


def test_an_edited_plan_is_refused_naming_the_manifest(tmp_path, done, capsys):
    out = tmp_path / "sw"
    shutil.copytree(done[0], out)
    path = out / "chunks" / "_manifest.json"
    manifest = json.loads(path.read_text())
    manifest["n_chunks"] = 2
    path.write_text(json.dumps(manifest))
    with pytest.raises(
        ValueError,
        match=r"_manifest.json: records 3 geometries in 2 chunks.*"
        r"the file was edited; remove .*chunks to recompute",
    ):
        run_unitcell_sweep(job_from_dict(JOB), out)
    path.write_text("{")  # half-written: the tool says how to recover
    with pytest.raises(ValueError, match=r"_manifest.json: not JSON.*remove .*chunks to recompute"):
        run_unitcell_sweep(job_from_dict(JOB), out)
    shutil.rmtree(out / "chunks")  # as the message says
    run_unitcell_sweep(job_from_dict(JOB), out)
    assert_same(out, done[1])


# ---- stopping ------------------------------------------------------------------------------------


def test_sigterm_stops_the_sweep_as_ctrl_c_does(tmp_path, monkeypatch, capsys, done):
    job, out = tmp_path / "job.toml", tmp_path / "sw"
    job.write_text(JOB_TOML)
    from dpfexplore.cli import unitcell as cli_unitcell

    real = cli_unitcell._chunks

    def terminate_after_the_first(display):
        shown = real(display)

        def progress(done_chunks, total):
            shown(done_chunks, total)
            signal.raise_signal(signal.SIGTERM)

        return progress

    previous = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(cli_unitcell, "_chunks", terminate_after_the_first)
    code = main(["unitcell", "sweep", str(job), "--out", str(out)])
    assert code == 143 and signal.getsignal(signal.SIGTERM) is previous
    err = capsys.readouterr().err.splitlines()
    assert err[-1] == (
        f"dpfexplore unitcell sweep: terminated (SIGTERM); 1 of 3 chunks (1 of 3 geometries) "
        f"are committed in {out}; continue with: dpfexplore unitcell sweep {job} --out {out}"
    )
    assert leftovers(tmp_path) == [] and not (out / "manifest.json").exists()
    seen = []
    run_unitcell_sweep(job_from_dict(JOB), out, progress=lambda d, t: seen.append(d))
    assert seen == [2, 3]
    assert_same(out, done[1])


def test_ctrl_c_says_what_is_committed(tmp_path):
    def interrupt(done_chunks, total):
        raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted) as stop:
        run_unitcell_sweep(job_from_dict(JOB), tmp_path / "sw", progress=interrupt)
    assert (stop.value.chunks_committed, stop.value.chunks_total) == (1, 3)
    assert (stop.value.geometries_committed, stop.value.geometries) == (1, 3)
    assert isinstance(stop.value, KeyboardInterrupt)


def test_a_dask_cluster_without_workers_is_reported_in_one_line(tmp_path, monkeypatch, caplog):
    from distributed import LocalCluster

    from dpfexplore.sweep import engines

    monkeypatch.setattr(engines, "_POLL_S", 0.1)
    monkeypatch.setattr(engines, "_NO_WORKER_NOTICE_S", 0.2)
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        started = time.perf_counter()
        with caplog.at_level(logging.WARNING), pytest.raises(SweepIncomplete) as failed:
            run_unitcell_sweep(
                job_from_dict(JOB),
                tmp_path / "sw",
                engine="dask",
                scheduler=cluster.scheduler_address,
                no_workers_timeout=0.5,
            )
        assert time.perf_counter() - started < 10.0
    message = str(failed.value)
    assert (
        "3 chunk(s) failed (first: part-0000" in message and "no Dask worker for 0.5 s" in message
    )
    notices = [r.getMessage() for r in caplog.records if "has no worker" in r.getMessage()]
    assert notices == [
        f"the Dask cluster {cluster.scheduler_address} has no worker; waiting up to 0.5 s for "
        "one, then the 3 remaining chunk(s) fail (committed chunks are kept; Ctrl-C stops)"
    ]


@settings(max_examples=40)
@given(data=st.data())
def test_a_mutated_job_file_is_read_or_refused_in_one_line_naming_it(tmp_path_factory, data):
    from dpfexplore.unitcell.sweep import read_job

    path = tmp_path_factory.mktemp("job") / "job.toml"
    text = JOB_TOML.encode()
    if data.draw(st.booleans()):  # one value of the job replaced by another TOML value
        line = data.draw(st.sampled_from([x for x in JOB_TOML.splitlines() if "=" in x]))
        value = data.draw(
            st.sampled_from(
                [
                    "0",
                    "-1",
                    "0.5",
                    "1e400",
                    "nan",
                    "inf",
                    '"x"',
                    "[]",
                    "[[1]]",
                    "{}",
                    "true",
                    "[3.0, -1.0]",
                    "99999999999999999999",
                    "1e-300",
                    "300",
                ]
            )
        )
        key = line.split("=")[0].strip()
        text = JOB_TOML.replace(line, f"{key} = {value}").encode()
    else:
        text = _flip(text, data.draw)
    path.write_bytes(text)
    try:
        job = read_job(path)
    except ValueError as exc:
        message = str(exc)
        assert message.startswith(f"{path}: ") and "\n" not in message
        return
    assert job.geometries.shape[1] == 5 and np.isfinite(job.geometries).all()


@settings(max_examples=6)
@given(data=st.data())
def test_a_mutated_chunk_file_is_traced_again(tmp_path_factory, done, data):
    out = tmp_path_factory.mktemp("chunk") / "sw"
    shutil.copytree(done[0], out)
    files = sorted((out / "chunks").glob("part-*.parquet"))
    target = data.draw(st.sampled_from(files))
    target.write_bytes(_flip(target.read_bytes(), data.draw))
    run_unitcell_sweep(job_from_dict(JOB), out)
    assert_same(out, done[1])
