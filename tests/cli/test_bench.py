"""Smoke runs of ``dpfexplore bench statics`` and ``bench sweep``: the records have their fields."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import reference_reset_times

from dpfexplore.cli import main


@pytest.mark.slow
def test_bench_statics_record(capsys, tmp_path, monkeypatch):
    import dpfexplore.bench.statics as bench_statics

    monkeypatch.chdir(tmp_path)
    # the per-design times the record summarises, captured to recompute its figures
    timed = []
    original = bench_statics._per_design_times

    def per_design_times(*args, **kwargs):
        timed.append(original(*args, **kwargs))
        return timed[-1]

    monkeypatch.setattr(bench_statics, "_per_design_times", per_design_times)
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
    # the median and p90 are those of the measured per-design times (one array per N, the
    # record's main figures are N = 2's), and every design solves faster than SciPy's median
    assert [len(t) for t in timed] == [r["designs"] for r in record["by_n_units"]]
    times = timed[0]
    assert 0 < record["designs"] <= 20 and np.all(times > 0)
    assert record["ours_us_per_design"] == pytest.approx(np.median(times), rel=1e-12)
    assert record["ours_us_per_design_p90"] == pytest.approx(np.percentile(times, 90), rel=1e-12)
    assert record["ours_us_per_design_p90"] < record["scipy_us_per_design"]
    assert record["speedup_vs_scipy"] == pytest.approx(
        record["scipy_us_per_design"] / np.median(times), rel=1e-12
    )
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
    # the errors meet the reset model's goals (GOALS of bench reset-model) on these designs
    assert reset["median_rel_err"] <= 0.01 and reset["p95_rel_err"] <= 0.05
    assert reset["max_rel_err"] <= 0.20 and reset["metastable_units"] > 0
    # the pick-and-place finger: units 1-4 never reset, the full model's times of units 5-6 are
    # those of the reference integration (SciPy Radau, tests/data/reference), the fast model's
    # within the goal's 2 % of them, and the recorded error is that of the two lists
    pick = reset["pickplace"]
    assert pick["reference"][:4] == [None] * 4 and pick["reset_times"][:4] == [None] * 4
    expected = reference_reset_times()
    np.testing.assert_allclose(pick["reference"][4:6], expected, rtol=1e-3)
    np.testing.assert_allclose(pick["reset_times"][4:6], expected, rtol=0.02)
    rel = np.abs(np.array(pick["reset_times"][4:6]) / np.array(pick["reference"][4:6]) - 1.0)
    assert pick["max_rel_err"] == pytest.approx(rel.max(), rel=1e-12)
