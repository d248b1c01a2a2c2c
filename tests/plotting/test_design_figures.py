"""Figures of the design scenes, checked by what they draw: the objective history draws every
target it lists, and the two-profile front shows t by colour with nothing clipped."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.figure import Figure

from dpfexplore.inverse.scenes.pickplace.figures import target_label as _target_label
from dpfexplore.plotting.design import plot_objective_history
from dpfexplore.plotting.timing import plot_difference_front


def axes():
    fig = Figure(figsize=(6, 5))
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot()


def history(per_target: dict[int, list[float]]) -> pd.DataFrame:
    rows = [
        {"evaluation": i, "target": target, "objective": value}
        for target, values in per_target.items()
        for i, value in enumerate(values)
    ]
    return pd.DataFrame(rows)


def test_objective_history_draws_every_target_it_lists():
    # target 0: four evaluations; 1: met at its first (one point); 2: no finite objective
    frame = history({0: [1e-2, 1e-2, 3e-3, 5e-7], 1: [6e-4], 2: [np.nan, np.inf]})
    fig, ax = axes()
    plot_objective_history(
        frame, ax=ax, labels={0: "reset 0.3 s", 1: "reset 1 s", 2: "reset 2 s"}, ylabel="rel"
    )
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["reset 0.3 s", "reset 1 s"]
    assert len(ax.lines) == 2
    first, single = ax.lines
    np.testing.assert_array_equal(first.get_xdata(), [1, 2, 3, 4])
    np.testing.assert_allclose(first.get_ydata(), [1e-2, 1e-2, 3e-3, 5e-7])
    # one evaluation is one visible marker, not an invisible one-point line
    assert len(single.get_xdata()) == 1 and single.get_marker() == "o"
    assert ax.get_ylabel() == "rel" and ax.get_yscale() == "log"
    # a few evaluations: a linear axis of whole numbers
    assert ax.get_xscale() == "linear"
    fig.canvas.draw()
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert all(float(t).is_integer() for t in ticks)
    low, high = ax.get_ylim()
    assert low <= 5e-7 and high >= 1e-2


def test_objective_history_of_many_evaluations_has_a_log_axis_and_default_labels():
    frame = history({0: list(np.geomspace(1.0, 1e-6, 40))})
    _, ax = axes()
    plot_objective_history(frame, ax=ax)
    assert ax.get_xscale() == "log"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["target 1"]
    assert ax.get_ylabel() == "best objective so far (mm²)"


def test_difference_front_shows_t_by_colour_and_keeps_every_point_inside():
    front = [
        (0.34, 0.06898, 0.85),
        (0.41, 0.06898, 0.80),
        (0.52, 0.06835, 0.75),
        (0.96, 0.06709, 0.95),
    ]
    lines = [(0.29, 0.06838), (0.51, 0.06684), (0.95, 0.06474)]
    fig, ax = axes()
    plot_difference_front(front, lines=lines, weighted=(0.41, 0.06898), ax=ax)
    fig.canvas.draw()
    # no text labels beside the points (they overlapped and were clipped): t is the colour
    assert len(ax.texts) == 0
    (dots,) = [c for c in ax.collections if isinstance(c, PathCollection)]
    np.testing.assert_allclose(dots.get_offsets(), [(d, k) for d, k, _ in front])
    np.testing.assert_allclose(dots.get_array(), [t for _, _, t in front])
    colorbars = [a for a in fig.axes if a is not ax]
    assert len(colorbars) == 1 and colorbars[0].get_ylabel() == "t (mm) of the front's designs"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "optimum of one line of t",
        "front (verified)",
        "weighted sum",
    ]
    # every point strictly inside the data limits (margins), so no marker is cut by the frame
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for d, k in [(d, k) for d, k, _ in front] + lines:
        assert x0 < d < x1 and y0 < k < y1
    assert ax.get_xlabel() == "RT_2 - RT_1 (s)" and ax.get_ylabel() == "grasp stiffness (N/mm)"


def test_pickplace_targets_are_named_as_the_scene_names_them():
    assert _target_label({"target_reset": 0.3}) == "reset 0.3 s"
    assert (
        _target_label({"target_units": [5, 6], "target_reset": [2.657, 1.613]})
        == "units 5, 6: reset 2.657, 1.613 s"
    )
    assert _target_label({"target_reset": None}) == "max RT_2 - RT_1"
