"""The validation figure: what each panel draws, its labels, one legend inside the figure."""

from __future__ import annotations

import itertools

import matplotlib
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from plotting.figure_checks import assert_readable

from dpfexplore.measurements import validate
from dpfexplore.plotting.validation import plot_finger_validation, plot_validation

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def result():
    return validate()


@pytest.fixture(scope="module")
def figure(result):
    fig = plot_validation(result.fingers)
    FigureCanvasAgg(fig).draw()  # laid out and drawn as savefig does
    return fig


def _panels(figure):
    return [ax for ax in figure.axes if ax.get_visible()]


def _by_finger(result):
    grouped = {}
    for r in result.fingers:
        grouped.setdefault(r.finger, []).append(r)
    return grouped


def test_one_panel_per_finger_with_each_set_s_lattice(figure, result):
    assert_readable(figure)  # the figure validate --plot saves
    grouped = _by_finger(result)
    panels = _panels(figure)
    assert len(panels) == len(grouped) == 13
    for ax, (name, rows) in zip(panels, grouped.items(), strict=True):
        title = ax.get_title()
        assert title.startswith(f"{name} ({rows[0].material})")
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (mm)", "y (mm)")
        # one labelled line per set: its limiting layer, through the predicted nodes
        labelled = [line for line in ax.lines if not line.get_label().startswith("_")]
        layers = [line for line in labelled if line.get_label() in ("paper", "shell-extended")]
        assert [line.get_label() for line in layers] == ["paper", "shell-extended"]
        for line, r in zip(layers, rows, strict=True):
            np.testing.assert_array_equal(line.get_xydata(), r.nodes[1::2])
        # hollow tips: the sets under which the measured state does not hold
        hollow = [line for line in ax.lines if line.get_markerfacecolor() == "white"]
        assert len(hollow) == sum(not r.holds for r in rows)
        for line, r in zip(hollow, [r for r in rows if not r.holds], strict=True):
            np.testing.assert_array_equal(line.get_xydata()[0], r.predicted_tip)


def test_the_measured_and_reference_tips_are_marked(figure, result):
    for ax, rows in zip(_panels(figure), _by_finger(result).values(), strict=True):
        marks = {line.get_label(): line.get_xydata()[0] for line in ax.lines}
        first = rows[0]
        if first.measured_tip is None:  # measured for stiffness: the ratios are in the title
            assert "measured tip" not in marks
            assert f"K/K meas. paper {first.stiffness_ratio:.2f}" in ax.get_title()
            continue
        np.testing.assert_array_equal(marks["measured tip"], first.measured_tip)
        np.testing.assert_array_equal(marks["reference tip"], first.reference_tip)
        assert f"paper {rows[0].distance:.1f} mm" in ax.get_title()
        # the measured tip lies inside the panel's view
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x0 < first.measured_tip[0] < x1 and y0 < first.measured_tip[1] < y1


def test_one_legend_inside_the_figure(figure):
    (legend,) = figure.legends
    texts = [t.get_text() for t in legend.get_texts()]
    assert texts[:2] == ["paper", "shell-extended"]
    assert "measured tip" in texts and any("other than measured" in t for t in texts)
    renderer = figure.canvas.get_renderer()
    box = legend.get_window_extent(renderer)
    page = figure.bbox
    assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1
    assert all(not ax.get_legend() for ax in figure.axes)


def _drawn_ticklabels(axis, limits):
    """The tick labels matplotlib draws: those of ticks inside the view limits."""
    low, high = sorted(limits)
    return [
        label
        for tick, label in zip(axis.get_ticklocs(), axis.get_ticklabels(), strict=True)
        if label.get_text() and low <= tick <= high
    ]


def test_no_text_overlaps(figure):
    renderer = figure.canvas.get_renderer()
    texts = [figure.legends[0]]
    for ax in _panels(figure):
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label]
        texts += _drawn_ticklabels(ax.xaxis, ax.get_xlim())
        texts += _drawn_ticklabels(ax.yaxis, ax.get_ylim())
    boxes = [t.get_window_extent(renderer) for t in texts]
    for (a, box_a), (b, box_b) in itertools.combinations(zip(texts, boxes, strict=True), 2):
        assert not box_a.overlaps(box_b), (a, b)


def test_one_finger_on_its_own_axes(result):
    rows = _by_finger(result)["cheetah-target-2"]
    ax = plot_finger_validation(rows)
    assert ax.get_title().startswith("cheetah-target-2 (Cheetah 95A)")
    with pytest.raises(ValueError, match="one finger"):
        plot_finger_validation(result.fingers[:14])
