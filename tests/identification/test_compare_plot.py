"""``identify compare --plot``: the model-uncertainty figure, checked by what it draws, and the
``--plot`` paths refused before any work."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection

from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.identification import compare as compare_module
from dpfexplore.identification.compare import compare_fingers
from dpfexplore.model.constants_set import DEFAULT, find_constants_set
from dpfexplore.model.design import load_design
from dpfexplore.plotting.compare import INF_LABEL, NAN_LABEL, plot_set_comparison, sequence_of

NAMES = ["shell-extended", "paper"]


@pytest.fixture(scope="module")
def fingers():
    sets = [find_constants_set("shell-extended"), DEFAULT]
    out = []
    for name in ("gripper", "pickplace"):
        states, resets = compare_fingers(sets, load_design(example_path(name)))
        out.append((name, states, resets))
    return out


@pytest.fixture(scope="module")
def figure(fingers):
    fig = plot_set_comparison(fingers, NAMES)
    FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig


def panels(fig):
    return np.array(fig.axes).reshape(3, -1)


def test_one_column_of_three_labelled_panels_per_design(figure, fingers):
    grid = panels(figure)
    assert grid.shape == (3, len(fingers))
    for column, (name, _, resets) in enumerate(fingers):
        tips, stiffness, reset = grid[:, column]
        assert tips.get_title().startswith(f"{name} ({len(resets)} units)")
        assert (tips.get_xlabel(), tips.get_ylabel()) == ("tip x (mm)", "tip y (mm)")
        assert stiffness.get_ylabel() == "tip stiffness (N/mm)"
        assert "sequential step" in stiffness.get_xlabel()
        assert (reset.get_xlabel(), reset.get_ylabel()) == ("unit", "reset time (s)")
        # one line per set in every panel, named after it
        for ax in (tips, stiffness, reset):
            assert [line.get_label() for line in ax.lines] == NAMES
    (legend,) = figure.legends
    assert [t.get_text() for t in legend.get_texts()][:2] == NAMES


def test_tips_and_stiffness_are_each_sets_sequence_in_order(figure, fingers):
    grid = panels(figure)
    for column, (_, states, resets) in enumerate(fingers):
        tips, stiffness, _ = grid[:, column]
        for line, name in zip(tips.lines, NAMES, strict=True):
            sequence = sequence_of(states, name)
            assert list(sequence["step"]) == list(range(len(resets) + 1))
            np.testing.assert_array_equal(line.get_xdata(), sequence["tip_x"])
            np.testing.assert_array_equal(line.get_ydata(), sequence["tip_y"])
            (x_low, x_high), (y_low, y_high) = tips.get_xlim(), tips.get_ylim()
            assert x_low < sequence["tip_x"].min() and sequence["tip_x"].max() < x_high
            assert y_low < sequence["tip_y"].min() and sequence["tip_y"].max() < y_high
        for line, name in zip(stiffness.lines, NAMES, strict=True):
            sequence = sequence_of(states, name)
            np.testing.assert_array_equal(line.get_ydata(), sequence["stiffness"])
            low, high = stiffness.get_ylim()
            assert low < sequence["stiffness"].min() and sequence["stiffness"].max() < high
        # the undeformed tip: one star where both sets start
        stars = [c for c in tips.collections if c.get_offsets().shape[0] == 1]
        start = sequence_of(states, NAMES[0]).iloc[0]
        assert any(np.allclose(c.get_offsets()[0], [start["tip_x"], start["tip_y"]]) for c in stars)
    # hollow markers: the states whose solve landed elsewhere than requested (under
    # shell-extended the gripper's first requested states fall back to the flat one)
    moved = [
        int((s["found"] != s["state"]).sum())
        for s in (sequence_of(fingers[0][1], name) for name in NAMES)
    ]
    assert moved[0] >= 2
    for ax in grid[:2, 0]:
        hollow = [
            c
            for c in ax.collections
            if isinstance(c, PathCollection) and np.allclose(c.get_facecolor()[0][:3], 1.0)
        ]
        assert sorted(len(c.get_offsets()) for c in hollow) == sorted(m for m in moved if m)


def test_reset_times_keep_inf_and_nan_on_labelled_rows(figure, fingers):
    grid = panels(figure)
    first = grid[2, 0]
    labels = [t.get_text() for t in first.get_yticklabels()]
    assert INF_LABEL in labels and NAN_LABEL in labels
    ticks = dict(zip(labels, first.get_yticks(), strict=True))
    for column, (_, _, resets) in enumerate(fingers):
        ax = grid[2, column]
        low, high = ax.get_ylim()
        for line, name in zip(ax.lines, NAMES, strict=True):
            times = resets[f"{name}:reset_time"].to_numpy(float)
            shown = np.asarray(line.get_ydata(), float)
            assert np.all((low < shown) & (shown < high))
            np.testing.assert_array_equal(shown[np.isfinite(times)], times[np.isfinite(times)])
            assert np.all(shown[np.isinf(times)] == ticks[INF_LABEL])
            assert np.all(shown[np.isnan(times)] == ticks[NAN_LABEL])
            finite = times[np.isfinite(times)]
            if finite.size:
                assert ticks[NAN_LABEL] < finite.min() and finite.max() < ticks[INF_LABEL]
    # the gripper: units 1-4 stay inverted under both sets; the fifth has no contact under
    # shell-extended and resets within the pulse's tail under the paper's set
    times = fingers[0][2]["shell-extended:reset_time"].to_numpy(float)
    assert np.isinf(times[:4]).all() and np.isnan(times[4])
    paper = fingers[0][2]["paper:reset_time"].to_numpy(float)
    assert np.isinf(paper[:4]).all() and 0.0 < paper[4] < 5.0


def test_compare_writes_the_figure_into_a_new_folder(tmp_path, capsys):
    path = tmp_path / "new" / "compare.png"
    argv = ["identify", "compare", "shell-extended", "--design", "gripper", "--plot", str(path)]
    assert main(argv) == 0
    assert "sequential states" in capsys.readouterr().out
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000


@pytest.mark.parametrize(
    ("name", "says"),
    [("compare.txt", "give a file name ending in .png"), ("file/compare.png", "cannot create")],
)
def test_bad_plot_paths_are_refused_before_any_work(tmp_path, capsys, monkeypatch, name, says):
    (tmp_path / "file").write_text("not a folder")

    def no_work(*args, **kwargs):
        raise AssertionError("computed before refusing --plot")

    monkeypatch.setattr(compare_module, "compare_fingers", no_work)
    argv = ["identify", "compare", "shell-extended", "--design", "gripper"]
    assert main([*argv, "--plot", str(tmp_path / name)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert says in err and "--plot" in err and "\n" not in err
    assert captured.out == ""
    assert not (tmp_path / name).exists()
