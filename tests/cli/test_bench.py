"""Smoke runs of ``dpfexplore bench statics`` and ``bench sweep``: the records have their fields."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dpfexplore.cli import main


@pytest.mark.slow
def test_bench_statics_record(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(
        [
            "bench",
            "statics",
            "--json",
            "--units",
            "2,3",
            "--designs",
            "20",
            "--scipy-designs",
            "2",
            "--rounds",
            "1",
            "--no-compile",
            "--save",
        ]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    assert record["n_units"] == 2 and len(record["by_n_units"]) == 2
    for key in (
        "ours_us_per_design",
        "ours_batch_mean_us_per_design",
        "scipy_us_per_design",
        "speedup_vs_scipy",
        "designs_per_s_all_cores",
    ):
        assert record[key] > 0
    # ours is converged far below the SciPy baseline's error, against the tight reference
    assert record["ours_tip_err_mm"] < 1e-9
    assert record["ours_at_least_as_accurate"] is True
    assert record["ours_us_per_design"] <= record["ours_us_per_design_p90"]
    assert np.isfinite(record["scipy_tip_err_all_mm"])
    saved = json.loads((tmp_path / "results" / "reports" / "bench-statics.json").read_text())
    assert saved["by_n_units"][1]["n_units"] == 3


@pytest.mark.slow
def test_bench_sweep_record(capsys, tmp_path, monkeypatch):
    from dpfexplore.bench.sweep import JOBS

    monkeypatch.chdir(tmp_path)
    code = main(
        [
            "bench",
            "sweep",
            "--json",
            "--jobs-dir",
            str(JOBS),
            "--repeats",
            "1",
            "--baseline-designs",
            "3",
            "--overnight-designs",
            "3",
            "--rss-designs",
            "0",
            "--skip-dask",
            "--no-compile",
        ]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    local = record["engines"]["local"]
    assert local["designs"] == 9000 and local["wall_s"] > 0 and local["peak_rss_mb"] > 0
    assert record["paper_job"]["one_at_a_time"]["max_abs_difference"] == 0.0
    assert record["overnight_outputs"]["designs_per_s"] > 0


@pytest.mark.slow
def test_bench_sensitivities_record(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = [
        "bench",
        "sensitivities",
        "--json",
        "--units",
        "2,3",
        "--designs",
        "4",
        "--reference-designs",
        "2",
        "--no-compile",
        "--save",
    ]
    assert main(args) == 0
    record = json.loads(capsys.readouterr().out)
    rows = record["by_n_units"]
    assert [r["n_units"] for r in rows] == [2, 3] and rows[1]["parameters"] == 12
    for r in rows:
        assert r["solve_us"] > 0 and r["sensitivities_us"] > 0 and r["fd_api_us"] > 0
        assert r["reference_designs"] >= 1
        # ours against the Richardson reference, which is itself good to ~1e-8
        assert r["ours_rel_err"] < 1e-6 and r["ours_stiffness_rel_err"] < 1e-5
    api = record["api"]
    assert [r["batch"] for r in api["solve_batch"]] == [1, 8, 64]
    assert all(r["ratio"] > 0 and r["ratio_sensitivities"] > 0 for r in api["solve_batch"])
    assert {r["design"] for r in api["find_state"]} == {"gripper", "pickplace"}
    saved = json.loads((tmp_path / "results" / "reports" / "bench-sensitivities.json").read_text())
    assert saved["by_n_units"][0]["n_units"] == 2


@pytest.mark.slow
def test_bench_surrogate_record_has_both_halves(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = [
        "bench",
        "surrogate",
        "--json",
        "--samples-per-n",
        "120",
        "--kinds",
        "knn",
        "--classifiers",
        "chain",
        "--reset-designs",
        "12",
    ]
    assert main(argv) == 0
    record = json.loads(capsys.readouterr().out)
    surrogates, reset = record["surrogates"], record["reset_model"]
    assert surrogates["kinds"] == ["knn"]
    exact = next(row for row in surrogates["speed"] if row["model"] == "exact")
    assert exact["tip_median"] == 0.0 and exact["us_batched"] > 0
    # the reset section is measured on the requested held-out designs, fallbacks included
    assert 0.0 <= reset["fallback_rate"] <= 1.0
    assert reset["us_per_design"] > 0 and reset["full_model_us_per_design"] > 0
    assert 0.0 <= reset["median_rel_err"] <= reset["p95_rel_err"] <= reset["max_rel_err"]
