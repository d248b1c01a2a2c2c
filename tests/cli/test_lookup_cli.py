"""``dpfexplore lookup`` through ``main([...])``: bad input is one line and exit code 2, an
incomplete dataset is said so, ``--write`` round-trips through ``dpfexplore states``, an
unreachable target gets the nearest design and a plot."""

from __future__ import annotations

import json
import shutil

import matplotlib
import numpy as np
import pytest
from plotting.figure_checks import assert_readable, captured_figures
from sweep_helpers import make_job

from dpfexplore.cli import main
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage import store

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """N = 3, 4, all units inverted, stiffness."""
    path = tmp_path_factory.mktemp("lookup-cli") / "inv"
    run_sweep(
        make_job(
            **{
                "job.name": "inv",
                "job.samples_per_n": 80,
                "job.chunk_size": 20,
                "space.n_units": [3, 4],
            }
        ),
        path,
    )
    return path


def copy_dataset(source, target):
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("_lookup*"))
    return target


def uncommit(path, keep):
    manifest = store.read_manifest(path)
    manifest.chunks = {p: r for p, r in manifest.chunks.items() if keep(r)}
    manifest.complete = False
    store.write_manifest(path, manifest)


def one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("dpfexplore lookup: error: ") and "\n" not in err
    return err


def test_bad_input_is_one_line_and_exit_code_2(dataset, tmp_path, capsys):
    d = str(dataset)
    assert "tip_z" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--columns", "tip_x,tip_z"]
    )
    assert "1 values for 2 columns" in one_line_error(capsys, ["lookup", d, "--target", "25"])
    assert "3 values for 2 columns" in one_line_error(capsys, ["lookup", d, "--target", "1,2,3"])
    assert "comma-separated" in one_line_error(capsys, ["lookup", d, "--target", "a,b"])
    assert "no such dataset" in one_line_error(
        capsys, ["lookup", str(tmp_path / "none"), "--target", "1,2"]
    )
    not_sweep = tmp_path / "plain"
    not_sweep.mkdir()
    assert "not a sweep directory" in one_line_error(
        capsys, ["lookup", str(not_sweep), "--target", "1,2"]
    )
    empty = copy_dataset(dataset, tmp_path / "empty")
    uncommit(empty, lambda r: False)
    assert "no usable rows" in one_line_error(capsys, ["lookup", str(empty), "--target", "1,2"])
    assert "no indexed rows match" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--n-units", "6..8"]
    )
    assert "n_units" in one_line_error(capsys, ["lookup", d, "--target", "1,2", "--n-units", "x"])
    assert "--where" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--where", "stiffness >"]
    )
    assert "colour" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--where", "colour > 1"]
    )
    assert "constraint" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--refine", "--constraints", "heights"]
    )
    assert "state" in one_line_error(capsys, ["lookup", d, "--target", "1,2", "--state", "12"])
    assert "k = 0" in one_line_error(capsys, ["lookup", d, "--target", "1,2", "--k", "0"])
    assert "constraints apply" in one_line_error(
        capsys, ["lookup", d, "--target", "1,2", "--constraints", "t=0.7"]
    )
    assert "finite" in one_line_error(capsys, ["lookup", d, "--target", "nan,2"])
    assert "scales" in one_line_error(capsys, ["lookup", d, "--target", "1,2", "--scales", "1,-1"])


def test_stale_index_refused_with_no_rebuild(dataset, tmp_path, capsys):
    path = copy_dataset(dataset, tmp_path / "data")
    assert main(["lookup", str(path), "--target", "30,20", "--k", "2"]) == 0
    manifest = store.read_manifest(path)
    manifest.chunks.pop(sorted(manifest.chunks)[-1])
    store.write_manifest(path, manifest)
    capsys.readouterr()
    assert "stale" in one_line_error(
        capsys, ["lookup", str(path), "--target", "30,20", "--no-rebuild"]
    )
    assert main(["lookup", str(path), "--target", "30,20", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["index"]["action"] == "rebuilt"
    assert any("stale" in note for note in record["notes"])


def test_incomplete_dataset_is_said_so(dataset, tmp_path, capsys):
    path = copy_dataset(dataset, tmp_path / "data")
    uncommit(path, lambda r: r.index == 0)
    assert main(["lookup", str(path), "--target", "30,20", "--k", "3"]) == 0
    out = capsys.readouterr().out
    assert "dataset incomplete: 40 of 160 designs committed" in out
    assert main(["lookup", str(path), "--target", "30,20", "--k", "3", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["dataset"]["complete"] is False
    assert record["dataset"]["designs_committed"] == 40
    assert any("committed chunks" in note for note in record["notes"])
    committed = set(store.read_results(path, columns=["design_id"])["design_id"])
    assert {c["source"]["design_id"] for c in record["candidates"]} <= committed


def test_write_round_trips_through_states(dataset, tmp_path, capsys):
    target = [31.0, 21.5]
    out_dir = tmp_path / "found"
    code = main(
        [
            "lookup",
            str(dataset),
            "--target",
            "31,21.5",
            "--k",
            "2",
            "--refine",
            "--json",
            "--write",
            str(out_dir),
        ]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    assert record["reachable"] is True and len(record["written"]) == 2
    met = 0
    for path, candidate in zip(record["written"], record["candidates"], strict=True):
        assert main(["states", path, "--json"]) in (0, 1)
        states = json.loads(capsys.readouterr().out)
        row = next(s for s in states["states"] if s["state"] == candidate["state"])
        assert row["status"] == "ok"
        assert row["tip"] == candidate["tip"]  # the same solve, to the last bit
        assert row["stiffness"] == pytest.approx(candidate["stiffness"], rel=1e-12)
        assert states["design"]["H"] == candidate["design"]["H"]
        if candidate["status"] == "ok":
            assert np.linalg.norm(np.array(row["tip"]) - target) <= 1e-6
            met += 1
    assert met >= 1 and record["candidates"][0]["status"] == "ok"
    assert record["candidates"][0]["fitted_range"] is True


def test_unreachable_target_gets_nearest_design_and_plot(dataset, tmp_path, capsys):
    plot = tmp_path / "reach.png"
    with captured_figures() as figures:
        code = main(
            [
                "lookup",
                str(dataset),
                "--target",
                "5,80",
                "--k",
                "2",
                "--refine",
                "--plot",
                str(plot),
                "--json",
            ]
        )
    assert code == 1
    (figure,) = figures
    assert_readable(figure)  # the legend beside the region, inside the figure
    record = json.loads(capsys.readouterr().out)
    assert record["reachable"] is False
    best = record["candidates"][0]
    assert best["status"] in ("not_met", "collapsed") and best["error_mm"] > 1.0
    assert best["error_mm"] <= record["candidates"][0]["source"]["distance"]
    assert any(
        "target not reached" in note and "nearest design" in note for note in record["notes"]
    )
    assert plot.exists() and plot.stat().st_size > 10_000


def test_table_output(dataset, capsys):
    assert (
        main(
            [
                "lookup",
                str(dataset),
                "--target",
                "30,20",
                "--k",
                "3",
                "--state",
                "all-inverted",
                "--n-units",
                "3..4",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith(f"lookup {dataset}: tip_x = 30, tip_y = 20")
    assert "status" in lines[1] and "stiffness" in lines[1]
    assert len([line for line in lines if line.strip().startswith(("1 ", "2 ", "3 "))]) == 3
    assert "re-solved by the exact model" in out
    # the distances' unit under their header, and what the columns' sources mean
    assert lines[2].split()[-1] == "mm" and "row dist" in lines[1]
    assert "key: error, row dist:" in out and "re-read:" in out


def test_query_prints_a_summary_that_fits_a_terminal(dataset, capsys):
    assert main(["query", str(dataset)]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert out.splitlines()[0].split() == [
        "design_id",
        "n_units",
        "requested_bits",
        "found_bits",
        "status_label",
        "tip_x",
        "tip_y",
        "stiffness",
    ]
    assert "--columns all for every one" in out
    assert main(["query", str(dataset), "--columns", "all", "--where", "design_id == 0"]) == 0
    assert "U_sep_1" in capsys.readouterr().out.splitlines()[0]


def test_no_match_names_only_the_filters_given(dataset, capsys):
    assert main(["lookup", str(dataset), "--target", "30,20", "--n-units", "9"]) == 2
    err = capsys.readouterr().err
    assert "n_units = 9 (the dataset has N = 3, 4)" in err and "None" not in err


@pytest.mark.slow
def test_bench_lookup_record(dataset, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = copy_dataset(dataset, tmp_path / "data")
    assert (
        main(
            [
                "bench",
                "lookup",
                "--dataset",
                str(path),
                "--builds",
                "1",
                "--queries",
                "8",
                "--targets",
                "3",
                "--tries",
                "2",
                "--no-sensitivities",
                "--json",
                "--save",
            ]
        )
        == 0
    )
    record = json.loads(capsys.readouterr().out)
    assert record["build"]["rows_read"] == 160 and record["build"]["build_s"] > 0
    for case in record["query"]["cases"].values():
        assert case["same_rows_as_scan"] is True and case["ours_ms"] > 0 and case["scan_ms"] > 0
    for name in ("exact", "central_differences"):
        refinement = record["refinement"][name]
        assert refinement["targets"] == 3 and 0 <= refinement["met_any_try"] <= 1
        assert refinement["worst_met_error_mm"] <= 1e-6
    assert record["refinement"]["speedup_vs_central"] > 0
    saved = tmp_path / "results" / "reports" / "bench-lookup.json"
    assert json.loads(saved.read_text())["benchmark"] == "lookup"


def test_a_chunk_changed_after_its_commit_is_refused(dataset, tmp_path, capsys):
    path = copy_dataset(dataset, tmp_path / "data")
    record = sorted(store.read_manifest(path).chunks.values(), key=lambda r: r.path)[0]
    chunk = path / record.path
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size, other bytes
    chunk.write_bytes(bytes(data))
    err = one_line_error(capsys, ["lookup", str(path), "--target", "30,20"])
    assert record.path in err and "SHA-256" in err


def test_designs_outside_the_fitted_range_are_flagged(tmp_path, capsys):
    path = tmp_path / "low"
    run_sweep(
        make_job(
            **{
                "job.name": "low",
                "job.samples_per_n": 30,
                "space.n_units": [2],
                "space.variables.H": {"min": 2.6, "max": 3.4},
                "space.variables.t": {"min": 0.5, "max": 0.7},
            }
        ),
        path,
    )
    assert main(["lookup", str(path), "--target", "30,12", "--k", "8", "--json"]) == 0
    candidates = json.loads(capsys.readouterr().out)["candidates"]
    flags = {c["fitted_range"] for c in candidates}
    assert flags == {True, False}  # the box straddles H = 3 mm
    for c in candidates:
        low = min(c["design"]["H"]) < 3.0
        assert c["fitted_range"] is not low
        assert (c["fitted_range_note"] is None) is not low
        if low:
            assert "below the fitted 3-5 mm" in c["fitted_range_note"]
    assert main(["lookup", str(path), "--target", "30,12", "--k", "8"]) == 0
    out = capsys.readouterr().out
    assert " NO " in out and "note: outside the fitted range of the closed forms: H[unit" in out
