"""The figure checker itself: each check rejects a figure made to break it, and lets the same
figure pass once the fault is removed (so a check that can never fail is caught here)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from plotting.figure_checks import check_figure


def _axes(size=(3.0, 3.0), layout=None):
    fig = Figure(figsize=size, dpi=50, layout=layout)
    if layout is None:  # room for the labels without a layout engine's cost
        fig.subplots_adjust(left=0.3, bottom=0.25, right=0.9, top=0.75)
    ax = fig.subplots()
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    return fig, ax


def _legend_at(ax, loc: str):
    ax.plot([], [], label="a key")
    return ax.legend(loc=loc)


def test_a_legend_over_a_disk_or_an_arrow_is_rejected():
    fig, ax = _axes()
    ax.add_patch(Circle((0.25, 0.75), 0.2, fill=False))  # its outline under the legend
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    _legend_at(ax, "upper left")
    assert any("covers axes 0 Circle" in p for p in check_figure(fig))
    ax.get_legend().set_loc("lower right")
    assert not check_figure(fig)
    # a filled disk the legend lies wholly inside, no outline under it: its area counts
    fig, ax = _axes()
    ax.add_patch(Circle((0.5, 0.5), 2.0, color="0.8"))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    _legend_at(ax, "center")
    assert any("Circle" in p for p in check_figure(fig))
    ax.patches[0].set_fill(False)
    assert not check_figure(fig)


def test_a_legend_over_contour_lines_or_a_filled_band_is_rejected():
    fig, ax = _axes()
    x = np.linspace(0.0, 1.0, 20)
    ax.contour(x, x, np.add.outer(x, x), levels=[0.3])  # a line across the lower left corner
    _legend_at(ax, "lower left")
    assert any("ContourSet" in p for p in check_figure(fig))
    ax.get_legend().set_loc("upper right")
    assert not check_figure(fig)
    fig, ax = _axes()
    ax.fill_between(x, -1.0, 2.0, color="C1", alpha=0.3)  # a band over the whole axes
    ax.set_ylim(0.0, 1.0)
    _legend_at(ax, "center")
    assert any("FillBetweenPolyCollection" in p for p in check_figure(fig))


def test_a_colour_map_is_ground_for_a_legend():
    fig, ax = _axes()
    x = np.linspace(0.0, 1.0, 8)
    ax.pcolormesh(x, x, np.add.outer(x, x), shading="nearest")
    _legend_at(ax, "upper right")
    assert not check_figure(fig)


def test_a_text_across_the_axes_frame_is_rejected():
    fig, ax = _axes()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_xlim(0.0, 1.0)
    text = ax.text(0.0, 0.5, "a mark centred on the frame", ha="center")
    assert any("crosses the axes' frame" in p for p in check_figure(fig))
    text.set_horizontalalignment("left")
    text.set_text("mark")
    assert not check_figure(fig)
    # an annotation of a data point, offset out of the frame, is rejected the same way
    ax.annotate("a label", (0.9, 0.5), xytext=(4, 0), textcoords="offset points")
    assert any("'a label' crosses" in p for p in check_figure(fig))


def test_a_title_over_a_suptitle_and_ticks_over_a_colorbar_label_are_rejected():
    fig, ax = _axes()
    ax.set_title("an axes title")
    fig.suptitle("a figure title")
    assert not check_figure(fig)
    ax.set_title("an axes title", y=1.25)  # lifted onto the suptitle
    assert any("title 'an axes title' overlaps figure title" in p for p in check_figure(fig))
    fig, ax = _axes((4.0, 3.0))
    colorbar = fig.colorbar(ax.pcolormesh(100.0 * np.arange(9.0).reshape(3, 3)), ax=ax)
    colorbar.set_label("a colour")
    assert not check_figure(fig)
    colorbar.ax.yaxis.labelpad = -8  # pulled onto its own tick labels
    assert any("y tick label '400' overlaps axes 1 y label" in p for p in check_figure(fig))


def test_a_figure_drawn_before_is_checked_as_a_fresh_one():
    fig, ax = _axes()
    ax.set_aspect("equal")
    ax.plot(np.linspace(0, 1, 9), np.linspace(0, 1, 9), label="a diagonal")
    ax.legend(loc="lower left")
    fresh = check_figure(fig)
    assert any("covers axes 0 line 0" in p for p in fresh)
    fig.canvas.draw()  # not stale now: the checker draws it once more, not twice
    assert check_figure(fig) == fresh
