"""``dpfexplore states``: table, JSON, plot and bad input."""

from __future__ import annotations

import json

import pytest
from conftest import read_reference, spy
from plotting.figure_checks import assert_readable

from dpfexplore.cli import main
from dpfexplore.examples import example_path


def test_json_lists_every_state_with_units_of_the_model(capsys):
    assert main(["states", str(example_path("gripper")), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["design"]["H"] == [3.8187, 4.1549, 4.5246, 4.8239, 2.5]
    states = {s["state"]: s for s in data["states"]}
    assert len(states) == 32 and sum(s["stable"] for s in states.values()) == 16
    s = states["11110"]
    assert s["found"] == "11110" and s["stable"] and s["status"] == "ok"
    assert s["tip"] == pytest.approx([46.5099407429, 36.0294188529], abs=1e-8)
    assert s["min_eig"] == pytest.approx(0.00893536, rel=1e-5)
    assert s["stiffness"] > 0
    assert states["11111"]["found"] == "11110" and not states["11111"]["stable"]


def test_sequential_table_with_gripper_apertures(capsys):
    assert (
        main(
            [
                "states",
                str(example_path("gripper")),
                "--sequential",
                "--gripper",
                "20.081",
                "-27.065",
            ]
        )
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    # header, units, 6 states, and the note: unit 5 (H = 2.5 mm) is outside the fitted range
    assert len(lines) == 2 + 6 + 1
    row = next(line for line in lines if line.startswith("11110"))
    assert row.split()[-1] == "35.04"
    assert lines[-1].startswith("note: outside the range the closed forms were fitted on")
    assert "H[unit 5] = 2.5 mm below the fitted 3-5 mm" in lines[-1]


def test_plot_writes_a_png(tmp_path, capsys, monkeypatch):
    import dpfexplore.plotting.statics as plotting

    drawn = spy(monkeypatch, plotting, "plot_states")
    out = tmp_path / "states.png"
    assert main(["states", str(example_path("pickplace")), "--sequential", "--plot", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert_readable(drawn[0].figure)
    check_pickplace_states_figure(drawn)


def check_pickplace_states_figure(drawn: list) -> None:
    """The figure of ``states pickplace --sequential``: the seven sequential states, each
    limiting layer ending at the seed implementation's tip (gripper_states.csv, design 2)."""
    import matplotlib.pyplot as plt

    (ax,) = drawn
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (mm)", "y (mm)")
    layers = [line for line in ax.get_lines() if line.get_linewidth() == 2.0]
    # 000000 ... 111100: the metastable units 5-6 fall back (111110 and 111111 collapse, in
    # the reference too), so five stable states are drawn
    sequence = ["000000", "100000", "110000", "111000", "111100"]
    assert [line.get_label() for line in layers] == sequence
    reference = read_reference("gripper_states.csv")
    reference = reference[reference.design == 2]
    lost = reference[reference.requested.isin(["b111110", "b111111"])]
    assert len(lost) > 0 and (lost.found != lost.requested).all()
    tips = {r.found[1:]: (r.tip_x, r.tip_y) for r in reference.itertuples()}
    for line in layers:
        state = line.get_label()
        end = (line.get_xdata()[-1], line.get_ydata()[-1])
        assert end == pytest.approx(tips[state], abs=1e-6), state
    # every tip lies inside the drawn data limits
    box = ax.dataLim.padded(1e-6)  # the reference's tips are rounded to ~1e-10 mm
    for line in layers:
        assert box.contains(*tips[line.get_label()])
    plt.close(ax.figure)


@pytest.mark.parametrize("body", ["[design]\nH = [4.0]\n", "not toml ["])
def test_bad_design_file_exits_2_with_one_line(tmp_path, capsys, body):
    path = tmp_path / "bad.toml"
    path.write_text(body)
    assert main(["states", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0]


def test_missing_file_exits_2(tmp_path, capsys):
    assert main(["states", str(tmp_path / "nope.toml")]) == 2
    assert "nope.toml" in capsys.readouterr().err


def test_help_states_units(capsys):
    with pytest.raises(SystemExit):
        main(["states", "--help"])
    assert "N/mm" in capsys.readouterr().out
