"""Every figure the CLI draws, checked by what it draws (:mod:`figure_checks`): no overlapping
text, no legend over data or outside the page, labelled axes; and, per figure, what the reader
needs to read it (one scale across the gripper's panels, keys for colours and markers, the
no-reset markers off the time scale, negative reset times named).

Figures of long computations (``design --plot``) are drawn from small inputs solved here; the
others through the command itself, in-process."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
import pytest
from plotting.figure_checks import assert_readable, captured_figures, check_figure

from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.model.constants import segment_height
from dpfexplore.model.design import Design, load_design
from dpfexplore.model.gripper import gripper_aperture
from dpfexplore.plotting.design import plot_front, plot_gripper, plot_target_shapes
from dpfexplore.plotting.dynamics import plot_reset_maps
from dpfexplore.solvers.statics import find_state


def _drawn(tmp_path, argv: list[str]) -> list:
    with captured_figures() as figures:
        assert main(argv) == 0
    assert figures
    return figures


def test_the_checker_finds_what_a_reviewer_rejects():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 3))
    ax = fig.subplots()
    x = np.linspace(0, 1, 50)
    ax.plot(x, x, label="a line through the upper left corner")
    ax.legend(loc="upper left")
    ax.set_ylabel("y")
    fig.text(0.5, 0.5, "over", fontsize=40)
    fig.text(0.5, 0.5, "twice", fontsize=40)
    problems = check_figure(fig)
    assert any("covers axes 0 line 0" in p for p in problems)
    assert any("overlaps" in p and "over" in p for p in problems)
    assert any("x tick labels but no x label" in p for p in problems)
    ax.get_legend().set_bbox_to_anchor((-0.9, 1.0))
    assert any("outside the figure" in p for p in check_figure(fig))


@pytest.fixture(scope="module")
def gripper_states():
    """The packaged gripper in its four targeted states, at the design's base angle and length."""
    design = load_design(example_path("gripper"))
    states = ["10000", "11000", "11100", "11110"]
    nodes = [find_state(design, s).nodes for s in states]
    h = float(segment_height(design.r_b, design.t_lim, design.t))
    apertures = [float(gripper_aperture(n[-1], h, 10.62, -45.0)) for n in nodes]
    return nodes, h, apertures, states


def test_gripper_panels_share_one_scale_and_one_y_label(gripper_states):
    nodes, h, apertures, states = gripper_states
    fig = plot_gripper(nodes, h, -45.0, 10.62, [70, 60, 45, 35], apertures, states=states)
    assert_readable(fig)
    axes = fig.axes
    assert len(axes) == 4
    assert len({ax.get_xlim() for ax in axes}) == 1 and len({ax.get_ylim() for ax in axes}) == 1
    assert [ax.get_ylabel() for ax in axes] == ["y (mm)", "", "", ""]
    # every finger and object inside the shared limits
    (x0, x1), (y0, y1) = axes[0].get_xlim(), axes[0].get_ylim()
    for ax in axes:
        for line in ax.lines:
            x, y = line.get_data()
            assert x0 <= np.min(x) and np.max(x) <= x1 and y0 <= np.min(y) and np.max(y) <= y1


def test_target_shapes_keep_the_legend_off_the_fingers():
    scene = {  # the position + stiffness scene's paper designs (jobs/design-position-stiffness)
        (46.0, 32.0): dict(H=[4.99, 4.88, 4.86, 4.15], U_sep=2.26, U_L=9.98, t=0.9, t_lim=1.89),
        (25.0, 20.0): dict(H=[4.66, 4.41, 4.31], U_sep=1.4, U_L=6.85, t=0.91, t_lim=1.95),
        (35.0, 45.0): dict(
            H=[4.9, 4.687, 4.57, 4.225, 4.2], U_sep=1.03, U_L=8.92, t=0.99, t_lim=1.94
        ),
    }
    nodes = [find_state(Design(**kw, E=26.0), "1" * len(kw["H"])).nodes for kw in scene.values()]
    ax = plot_target_shapes(nodes, list(scene), [True, True, False])
    assert_readable(ax.figure)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["target 1", "target 2", "target 3"]


def test_front_figure_is_readable():
    points = [(0.001, 8e-4, 0.1711), (0.01, 9e-3, 0.1712), (0.1, 0.09, 0.1716), (1.0, 0.9, 0.1758)]
    ax = plot_front(points, reference=(0.27, 0.1474), title="target 1 [46.0, 32.0]")
    assert_readable(ax.figure)


def test_simulation_legend_hides_no_snap_back(tmp_path):
    (fig,) = _drawn(tmp_path, ["simulate", "pickplace", "--plot", str(tmp_path / "run.png")])
    assert_readable(fig)
    extensions = fig.axes[1]
    labels = [t.get_text() for t in extensions.get_legend().get_texts()]
    assert "unit 5 (metastable)" in labels and "unit 6 (metastable)" in labels
    renderer = fig.canvas.get_renderer()
    legend = extensions.get_legend().get_window_extent(renderer)
    assert legend.x0 >= extensions.get_window_extent(renderer).x1  # beside the curves


def test_unit_cell_figure_keys_its_colours_and_markers(tmp_path):
    (fig,) = _drawn(
        tmp_path,
        ["unitcell", "curve", "--H", "3", "--t", "0.83", "--plot", str(tmp_path / "d.png")],
    )
    assert_readable(fig)
    force, _energy, meridians = fig.axes
    keys = [t.get_text() for t in force.get_legend().get_texts()]
    branches = [k for k in keys if k.startswith("branch ")]
    assert branches == [f"branch {k}" for k in range(len(branches))] and len(branches) >= 2
    assert {"stable", "unstable", "zero force, stable", "zero force, unstable"} <= set(keys)
    colour = {
        line.get_label(): line.get_color() for line in force.lines if line.get_label() in branches
    }
    # each meridian in its branch's colour, as its legend entry says
    for line in meridians.lines:
        branch = line.get_label().rpartition(", ")[2]
        assert line.get_color() == colour[branch]


def test_set_comparison_of_one_design_keeps_its_legend_on_the_page(tmp_path):
    argv = ["identify", "compare", "shell-extended", "--design", "gripper"]
    (fig,) = _drawn(tmp_path, [*argv, "--plot", str(tmp_path / "c.png")])
    assert_readable(fig)


def _reset_map(name: str, values, times, **fixed) -> pd.DataFrame:
    n = len(values)
    frame = {"map": name, "value": values, "reset_time": times, "n_units": 1, "unit": 1}
    frame.update({"H": 3.0, "t": 0.8, "hold": 4.0, "horizon": 30.0, "status": "ok"})
    frame.update(fixed)
    return pd.DataFrame({k: v if np.ndim(v) else [v] * n for k, v in frame.items()})


def test_reset_maps_draw_no_reset_off_the_scale_and_name_negative_times():
    maps = {
        "H": _reset_map("H", [2.6, 2.9, 3.2], [0.0075, 0.0327, np.inf], H=[2.6, 2.9, 3.2]),
        "t": _reset_map("t", [0.75, 0.85, 1.0], [np.inf, 0.0171, -0.0258], t=[0.75, 0.85, 1.0]),
        "hold": _reset_map("hold", [0.05, 1.0], [0.0327, 0.0327], H=2.9),
    }
    fig = plot_reset_maps(maps)
    assert_readable(fig)
    heights, thickness, _ = fig.axes
    for ax, x_never in ((heights, 3.2), (thickness, 0.75)):
        (never,) = [line for line in ax.lines if line.get_marker() == "^" and len(line.get_xdata())]
        # on the top edge (axes fraction 1), not at a time of the scale
        assert never.get_transform() == ax.get_xaxis_transform()
        assert list(never.get_xdata()) == [x_never] and list(never.get_ydata()) == [1.0]
        assert not any(np.isinf(line.get_ydata()).any() for line in ax.lines)
    labels = [t.get_text() for t in thickness.get_legend().get_texts()]
    assert any("reset during the ramp" in label for label in labels)
    zero = [line for line in thickness.lines if len(line.get_ydata()) and line.get_ls() == "--"]
    assert [list(line.get_ydata()) for line in zero] == [[0.0, 0.0]]
    assert not any("reset during" in t.get_text() for t in heights.get_legend().get_texts())
