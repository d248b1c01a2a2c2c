"""``dpfexplore simulate``, ``dpfexplore reset-maps`` and ``dpfexplore bench dynamics``."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from conftest import reference_reset_times, spy
from plotting.figure_checks import assert_readable, captured_figures

import dpfexplore.cli as cli
import dpfexplore.cli.bench as cli_bench
from dpfexplore.examples import example_path


@pytest.fixture
def main(monkeypatch):
    """The CLI with the dynamics commands registered (independent of the other commands)."""
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("finger.simulate", "finger.resetmaps", "bench"))
    monkeypatch.setattr(cli_bench, "BENCHMARKS", ("dynamics",))
    return cli.main


def test_simulate_json(main, capsys):
    code = main(
        [
            "simulate",
            str(example_path("pickplace")),
            "--P0",
            "0.7",
            "--tau",
            "0,1,5,5.1",
            "--t-end",
            "15",
            "--json",
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["final_state"] == "111100"
    assert out["reset_times"][:4] == ["inf"] * 4
    # the reference integration's reset times (SciPy Radau, tests/data/reference)
    np.testing.assert_allclose(out["reset_times"][4:6], reference_reset_times(), rtol=1e-3)
    assert out["snap_back"][:4] == [None] * 4
    assert out["classes"] == ["bistable"] * 4 + ["metastable"] * 2
    assert out["status"] == "ok" and out["method"] == "rodas4"


def test_simulate_never_inverted_is_null_and_plot(main, capsys, tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    import dpfexplore.plotting.dynamics as plotting

    drawn = spy(monkeypatch, plotting, "plot_simulation")
    design = tmp_path / "weak.toml"
    design.write_text("[design]\nH = [4.0, 3.0]\nU_L = 6.0\nU_sep = 1.0\nt = 0.83\nt_lim = 1.0\n")
    png = tmp_path / "run.png"
    code = main(
        [
            "simulate",
            str(design),
            "--P0",
            "0.05",
            "--tau",
            "0,0.1,0.3,0.4",
            "--t-end",
            "1",
            "--json",
            "--plot",
            str(png),
        ]
    )
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reset_times"] == [None, None] and out["classes"] == [None, None]
    assert out["final_state"] == "00"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    # what is drawn: tip displacement over 0-1 s with the 0.05 MPa pulse on the twin axis, and
    # the two domes' extensions, both below their inversion thresholds (never inverted)
    (axes,) = drawn
    top, bottom = axes
    assert_readable(top.figure)
    assert top.get_xlabel() == "time (s)" and top.get_ylabel() == "tip displacement (mm)"
    (tip,) = top.get_lines()
    assert tip.get_xdata()[0] == 0.0 and tip.get_xdata()[-1] == pytest.approx(1.0)
    assert tip.get_ydata()[0] == 0.0 and tip.get_ydata().max() > 0
    (twin,) = [a for a in top.figure.axes if a not in (top, bottom)]
    (pressure,) = twin.get_lines()
    assert pressure.get_ydata().max() == pytest.approx(0.05)
    assert bottom.get_ylabel() == "dome extension x̄/d"
    units = [line for line in bottom.get_lines() if line.get_label().startswith("unit")]
    thresholds = [  # the dotted horizontal lines of the units (not legend-only entries)
        line
        for line in bottom.get_lines()
        if line.get_linestyle() == ":" and len(line.get_ydata()) and line.get_label()[0] == "_"
    ]
    assert [line.get_label() for line in units] == ["unit 1", "unit 2"] and len(thresholds) == 2
    for extension, threshold in zip(units, thresholds, strict=True):
        assert 0 < extension.get_ydata().max() < threshold.get_ydata()[0]
    plt.close(top.figure)


def test_simulate_text_and_profile(main, capsys):
    code = main(
        [
            "simulate",
            "pickplace",
            "--profile",
            "0:0,0.2:0.7,0.5:0.7,0.55:0",
            "--t-end",
            "3",
            "--method",
            "rodas4-overdamped",
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "rodas4-overdamped" in text and "final state" in text


@pytest.mark.parametrize(
    "argv, message",
    [
        (["simulate", "no-such-file.toml"], "no such design"),
        (["simulate", "pickplace", "--tau", "0,1,5"], "--tau"),
        (["simulate", "pickplace", "--t-end", "3"], "t_end"),
        (["simulate", "pickplace", "--profile", "0-0,1-1"], "profile"),
    ],
)
def test_simulate_bad_input_exits_2(main, capsys, argv, message):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_reset_maps_writes_parquet_and_png(main, capsys, tmp_path, monkeypatch):
    import dpfexplore.plotting.dynamics as plotting

    drawn = spy(monkeypatch, plotting, "plot_reset_maps")
    code = main(["reset-maps", "--quick", "--out", str(tmp_path)])
    assert code == 0
    for name in ("H", "t", "hold"):
        frame = pd.read_parquet(tmp_path / f"reset_map_{name}.parquet")
        assert {"value", "H", "t", "hold", "unit", "reset_time", "unit_class", "status"} <= set(
            frame.columns
        )
        assert (frame["status"] == "ok").all()
    h_map = pd.read_parquet(tmp_path / "reset_map_H.parquet").sort_values("value")
    # lower domes are further from bistability: they reset sooner; the 3.2 mm one never does
    finite = h_map[np.isfinite(h_map.reset_time)]
    assert finite.reset_time.is_monotonic_increasing and np.isinf(h_map.reset_time.iloc[-1])
    assert (tmp_path / "reset_maps.png").read_bytes()[:4] == b"\x89PNG"
    # each range printed "low to high" (a negative low is no dash), a negative time explained
    out = capsys.readouterr().out
    t_map = pd.read_parquet(tmp_path / "reset_map_t.parquet")
    times = t_map.reset_time[np.isfinite(t_map.reset_time)]
    assert f"reset times {times.min():.4g} to {times.max():.4g} s" in out
    assert ("snapped back during the ramp" in out) == bool((times < 0).any())
    # the figure: one panel per map; the H panel draws the parquet's finite reset times
    (fig,) = drawn
    assert_readable(fig)  # the quick maps' figure as reset-maps saves it
    axes = fig.axes
    assert [ax.get_xlabel() for ax in axes] == [
        "dome height H (mm)",
        "dome thickness t (mm)",
        "hold time (s)",
    ]
    curves = [  # solid lines in data coordinates: the finite reset times
        line
        for line in axes[0].get_lines()
        if line.get_linestyle() == "-" and line.get_transform() == axes[0].transData
    ]
    points = np.concatenate([np.column_stack(line.get_data()) for line in curves])
    expected = np.column_stack([finite.value, finite.reset_time])
    np.testing.assert_allclose(
        points[np.lexsort(points.T[::-1])], expected[np.lexsort(expected.T[::-1])]
    )
    assert "reset_map_hold.parquet" in out


@pytest.mark.slow
def test_bench_dynamics_json(main, capsys, tmp_path, monkeypatch):
    """A tiny run of the benchmark: one record per method, the Radau baseline's time."""
    monkeypatch.chdir(tmp_path)
    with captured_figures() as figures:
        code = main(
            [
                "bench",
                "dynamics",
                "--json",
                "--designs",
                "2",
                "--radau-designs",
                "1",
                "--explicit-designs",
                "0",
                "--no-compile",
                "--save",
            ]
        )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    methods = {r["method"] for r in record["records"]}
    assert {"rodas4", "rodas4-overdamped", "release", "scipy-radau"} <= methods
    for r in record["records"]:
        assert r["us_per_design"] > 0 and np.isfinite(r["reset_time_rel_err"])
    assert record["radau_baseline_us_per_design"]["pickplace"] > 0
    assert (tmp_path / "results" / "reports" / "bench-dynamics.png").exists()
    (figure,) = figures
    assert_readable(figure)
