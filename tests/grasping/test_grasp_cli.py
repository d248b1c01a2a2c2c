"""``dpfexplore grasp``: the table, strict JSON, the figure's artists, refusals, the tip's reset."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest
from plotting.figure_checks import assert_readable, captured_figures

from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.grasping import grasp, gripper_of
from dpfexplore.grasping.grasp import tip_reset_time
from dpfexplore.model.design import load_design

KEYS = {"state", "contact", "grip_force_N", "sensor", "threshold", "payload_kg", "holds"}


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def gripper():
    return gripper_of(load_design(example_path("gripper")))


@pytest.fixture(scope="module")
def cli_json():
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["grasp", "gripper", "--object", "45:0.002", "--lift-s", "0.02", "--json"])
    return code, out.getvalue()


def test_json_holds_the_issue_keys_and_agrees_with_the_apertures(cli_json, gripper):
    code, text = cli_json
    assert code == 0
    doc = _strict(text)
    rows = doc["states"]
    assert [r["state"] for r in rows] == list(gripper.states)
    for row, aperture in zip(rows, gripper.apertures, strict=True):
        assert KEYS <= set(row)
        assert isinstance(row["contact"], bool) and isinstance(row["holds"], bool)
        # a 45 mm disk touches exactly the states whose free aperture is smaller
        if row["holds"]:
            assert row["contact"] == (aperture < 45.0)
        assert row["threshold"] == doc["threshold_N"]
        assert row["carries"] == (row["holds"] and row["payload_kg"] >= 0.002)
        assert (row["grip_force_N"] > 0) == row["contact"]
    # 44.86 mm < 45 mm < 59.95 mm: the first state whose aperture is smaller decides
    assert doc["size_state"] == "11100"
    decided = rows[2]
    assert decided["sensor"] > decided["threshold"] > rows[1]["sensor"]
    assert doc["tip_reset_s"] > 0 and doc["lift_s"] == 0.02
    assert doc["tip_lasts"] == (doc["tip_reset_s"] >= 0.02)


def test_table_prints_every_state_and_the_tip_line(capsys):
    assert main(["grasp", "gripper", "--object", "45"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    for state in ("10000", "11000", "11100", "11110"):
        assert sum(line.startswith(state) for line in lines) == 1
    assert "size class: 11100" in out
    assert "tip unit (inverted by its pulse): resets after" in out and "not checked" in out


def test_figure_draws_both_fingers_the_disk_and_one_arrow_per_contact(gripper):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, FancyArrow

    from dpfexplore.plotting.grasp import plot_grasp

    report = grasp(gripper, 45.0, mu=0.5)
    s = report.states[2]
    ax = plot_grasp(
        s.nodes_mm,
        s.forces_N,
        s.points_mm,
        s.normals,
        base_l=gripper.base_L,
        depth=report.depth_mm,
        diameter=45.0,
        title=s.state,
        ax=plt.figure(figsize=(4.5, 4.5), dpi=40).add_subplot(),
    )
    assert len(ax.lines) == 2  # one outline per finger
    mirrored = ax.lines[1].get_ydata()
    assert np.allclose(mirrored, 2 * gripper.base_L - ax.lines[0].get_ydata())
    disks = [p for p in ax.patches if isinstance(p, Circle)]
    assert len(disks) == 1 and disks[0].radius == 22.5
    assert disks[0].center == (report.depth_mm, gripper.base_L)
    arrows = [p for p in ax.patches if isinstance(p, FancyArrow)]
    assert len(arrows) == 2 * int(np.sum(s.forces_N > 0)) >= 2
    assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title() == "11100"
    legend = ax.get_legend()
    assert legend.get_texts()[0].get_text() == "fingers"
    ax.figure.canvas.draw()
    inside = ax.get_window_extent()
    box = legend.get_window_extent()
    assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 <= inside.y1
    plt.close(ax.figure)


def test_plot_option_writes_the_figure(tmp_path, capsys):
    path = tmp_path / "fig" / "grasp.png"
    with captured_figures() as figures:
        assert main(["grasp", "gripper", "--object", "40", "--plot", str(path)]) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (figure,) = figures
    assert_readable(figure)  # each panel's legend in a band above its fingers and disk


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--object", "0"], "diameter = 0 mm"),
        (["--object", "-3"], "diameter = -3 mm"),
        (["--object", "200"], "diameter = 200 mm: larger than the open gripper"),
        (["--object", "45:-0.1"], "mass = -0.1 kg"),
        (["--object", "45", "--mu", "-0.5"], "--mu -0.5"),
        (["--object", "45:x"], "--object '45:x'"),
    ],
)
def test_bad_input_is_one_line_and_nothing_is_computed(argv, named, capsys, monkeypatch):
    api = importlib.import_module("dpfexplore.grasping.grasp")

    def refuse(*args, **kwargs):
        raise AssertionError("grasp ran on refused input")

    monkeypatch.setattr(api, "grasp", refuse)
    assert main(["grasp", "gripper", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = [line for line in captured.err.splitlines() if "compiling" not in line]
    assert len(lines) == 1 and named in lines[0] and lines[0].startswith("dpfexplore grasp: error")


def test_tip_reset_time_is_the_dynamics_reset_of_the_metastable_tip():
    from dpfexplore.model.design import DesignBatch
    from dpfexplore.model.pressure import PressureProfile
    from dpfexplore.solvers.dynamics.simulate import reset_times_batch

    design = load_design(example_path("gripper"))
    pulse = PressureProfile.pulse(0.7, (0.0, 0.5, 1.0, 1.1))
    out = reset_times_batch(DesignBatch.from_designs([design]), pulse, t_end=2.0)
    reset = tip_reset_time(design)
    n = design.n_units
    assert reset == out["reset_time"][0, n - 1]
    # the tip is the one metastable unit: it snaps back `reset` after the pulse ends (1.1 s);
    # the bistable units stay inverted
    assert out["unit_class"][0, n - 1] == 1 and np.all(out["unit_class"][0, : n - 1] == 0)
    assert out["snap_back"][0, n - 1] == pytest.approx(1.1 + reset, abs=1e-12)
    assert 0 < reset < 1.0 and np.all(np.isinf(out["reset_time"][0, : n - 1]))


def test_the_base_comes_from_base_then_the_files_result_then_the_paper(tmp_path, capsys):
    """A designed gripper's file names its base in [result]: grasp and sort close on that base."""
    from dpfexplore.model.gripper import PAPER_GRIPPER_BASE, gripper_aperture

    design = load_design(example_path("gripper"))
    text = example_path("gripper").read_text()
    path = tmp_path / "designed.toml"
    path.write_text(text + "\n[result]\nbase_L = 24.0\ntheta_B_deg = -20.0\n")

    def apertures(argv, base):
        assert main(["grasp", *argv, "--object", "40", "--json"]) == 0
        document = json.loads(capsys.readouterr().out)
        assert (document["base_L_mm"], document["theta_B_deg"]) == pytest.approx(base)
        return [s["aperture_mm"] for s in document["states"]]

    from dpfexplore import find_state
    from dpfexplore.solvers.lattice import lattice_params

    n = design.n_units
    tips = np.array([find_state(design, "1" * k + "0" * (n - k)).tip for k in range(1, n)])
    h = lattice_params(design).h
    for argv, base in (
        ([str(path)], (24.0, -20.0)),
        ([str(path), "--base", "22", "-25"], (22.0, -25.0)),
        (["gripper"], PAPER_GRIPPER_BASE),
    ):
        expected = gripper_aperture(tips, h, *base)
        np.testing.assert_allclose(apertures(argv, base), expected, rtol=0, atol=1e-9)
    # the text output says which base it closed on
    assert main(["grasp", str(path), "--object", "40"]) == 0
    assert "base_L 24 mm, theta_B -20 deg (designed.toml [result])" in capsys.readouterr().out
    # half a base, or a base that is no number: one line, nothing computed
    path.write_text(text + "\n[result]\nbase_L = 24.0\n")
    assert main(["grasp", str(path), "--object", "40"]) == 2
    assert "[result] has base_L but not the other" in capsys.readouterr().err
    path.write_text(text + '\n[result]\nbase_L = "x"\ntheta_B_deg = -20.0\n')
    objects = Path(__file__).parents[2] / "jobs" / "sort-objects.csv"
    assert main(["sort", str(path), str(objects)]) == 2
    assert "base_L = 'x': must be a finite number" in capsys.readouterr().err
