"""The snap figure as `dpfexplore snap --plot` draws it: one title and one pressure label for the
column of panels, every state label inside its panel, clear of the curves and of each other."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Annotation
from plotting.figure_checks import assert_readable

from dpfexplore import load_design, snap_pressures
from dpfexplore.examples import example_path
from dpfexplore.plotting.snap import plot_snap


@pytest.fixture(scope="module")
def drawn():
    sequence = snap_pressures(load_design(example_path("gripper")), P_max=0.7, direction="cycle")
    fig = Figure(figsize=(7, 7), layout="constrained")  # as the CLI's --plot
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 1, sharex=True)
    plot_snap(sequence, axes[0], quantity="u")
    plot_snap(sequence, axes[1], quantity="tip")
    fig.canvas.draw()
    return sequence, fig, axes


def labels(ax) -> list[Annotation]:
    return [t for t in ax.texts if isinstance(t, Annotation)]


def test_one_title_and_one_pressure_label_for_the_column(drawn):
    _, fig, (top, bottom) = drawn
    assert_readable(fig)  # the keys beside the panels, off the snaps at the highest pressures
    assert top.get_title().startswith("slow ramp (cycle), snaps at ") and bottom.get_title() == ""
    assert top.get_xlabel() == "" and bottom.get_xlabel() == "chamber pressure (MPa)"
    assert top.get_ylabel() == "dome extension u = x̄/d" and bottom.get_ylabel() == "tip (mm)"
    assert [t.get_text() for t in top.get_legend().get_texts()] == [
        f"unit {k}" for k in range(1, 6)
    ]


def test_every_snap_has_its_line_and_its_state(drawn):
    sequence, _, axes = drawn
    snaps = sorted(sequence.snaps, key=lambda e: e.pressure)
    assert len(snaps) == 6  # five rising, one falling (the cycle)
    for ax in axes:
        assert [t.get_text() for t in labels(ax)] == [e.after for e in snaps]
        vertical = [line for line in ax.lines if line.get_xdata()[0] == line.get_xdata()[-1]]
        assert {float(line.get_xdata()[0]) for line in vertical} >= {e.pressure for e in snaps}


def test_state_labels_stand_inside_the_frame_clear_of_curves_and_of_each_other(drawn):
    _, fig, axes = drawn
    renderer = fig.canvas.get_renderer()
    for ax in axes:
        frame = ax.get_window_extent(renderer)
        boxes = [t.get_window_extent(renderer) for t in labels(ax)]
        for box in boxes:
            assert frame.x0 < box.x0 and box.x1 < frame.x1
            assert frame.y0 < box.y0 and box.y1 < frame.y1 - 1.0  # not touching the frame
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                assert not a.overlaps(b)
        # no point of a branch (the solid curves) under a label
        curves = [line for line in ax.lines if line.get_linestyle() == "-" and line.get_label()]
        points = np.vstack([ax.transData.transform(line.get_xydata()) for line in curves])
        for box in boxes:
            inside = (
                (points[:, 0] >= box.x0)
                & (points[:, 0] <= box.x1)
                & (points[:, 1] >= box.y0)
                & (points[:, 1] <= box.y1)
            )
            assert not inside.any()
        # the headroom: the curves end below the labels
        top_of_curves = max(np.nanmax(line.get_ydata()) for line in curves)
        assert ax.get_ylim()[1] > top_of_curves
        assert all(isinstance(line, Line2D) for line in curves)
