"""The design reports' figures of the timing scenes and the surrogate's chart, built in-process
by the functions the reports save them with (``design --plot``, ``surrogate train``), from small
results of the shapes those reports pass, and checked by :mod:`figure_checks`."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from types import SimpleNamespace

import numpy as np
import pandas as pd
from plotting.figure_checks import assert_readable

from dpfexplore.inverse.scenes.pickplace.figures import (
    front_figure,
    objective_figure,
    reset_map_figure,
)
from dpfexplore.inverse.scenes.walker.report import timing_figure, tip_path_figure
from dpfexplore.surrogates.report import report_figures


def test_pickplace_reset_map_keeps_its_legend_off_the_grid():
    # the screening grid of the scenes in tests/inverse/test_timing_scenes.py: t = 6, H = 21
    H, t = (a.ravel() for a in np.meshgrid(np.linspace(2.9, 3.4, 21), np.linspace(0.8, 1.0, 6)))
    value = 0.3 * np.exp(6.0 * (H - 2.9)) * t
    value[H > 3.3] = np.inf  # bistable: never resets
    admissible = ~((H < 2.95) & (t > 0.95))
    designs = [(3.12, 0.9, "1.0"), (2.9, 0.8, "max diff")]  # one on the grid's lowest corner
    fig = reset_map_figure(H, t, value, admissible, designs, method="grid", h_label="H_5 (mm)")
    assert_readable(fig)
    ax = fig.axes[0]
    # every grid point inside the axes, above the legend's band
    assert ax.get_ylim()[0] < 0.8 and ax.get_ylim()[1] > 1.0


def test_pickplace_objective_and_front_are_readable():
    history = pd.DataFrame(
        [
            {"evaluation": i, "target": k, "objective": v}
            for k, values in enumerate([np.geomspace(1.0, 1e-3, 30), np.geomspace(0.5, 1e-6, 12)])
            for i, v in enumerate(values)
        ]
    )
    rows = [{"target_reset": 0.3}, {"target_units": [5, 6], "target_reset": [2.657, 1.613]}]
    fig = objective_figure(history, rows)
    assert_readable(fig)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["reset 0.3 s", "units 5, 6: reset 2.657, 1.613 s"]
    point = {"difference": 0.34, "stiffness": 0.06898, "design": {"t": 0.85}}
    row = {
        "front": [
            point,
            {"difference": 0.52, "stiffness": 0.06835, "design": {"t": 0.75}},
            {"difference": 0.96, "stiffness": 0.06709, "design": {"t": 0.95}},
        ],
        "lines": [{"difference": 0.29, "stiffness": 0.06838, "ok": True}],
        "weighted": point,
    }
    assert_readable(front_figure(row))


def _run(radius: float) -> SimpleNamespace:
    """A leg run as the walker's figures read it: a closed loop of the tip through its start."""
    a = np.linspace(0.0, 2.0 * np.pi, 120)
    path = np.column_stack([radius * (np.cos(a) - 1.0), radius * np.sin(a), radius * np.sin(2 * a)])
    return SimpleNamespace(tip_path=path, fitted_range=False, leg=SimpleNamespace(name="front"))


def test_walker_tip_path_keeps_its_legend_off_the_paths():
    labels = [
        "designed front leg, walking",
        "designed front leg, turning (phase 2 raised)",
        "monostable leg, same gait",
    ]
    title = "walker: front leg, stride 2.71 mm vs 1.20 mm (monostable)"
    fig = tip_path_figure([_run(1.3), _run(1.0), _run(0.6)], labels, title)
    assert_readable(fig)
    legend = fig.axes[0].get_legend()
    assert [t.get_text() for t in legend.get_texts()][:3] == [
        f"{label} (outside fitted H/t/E)" for label in labels
    ]
    renderer = fig.canvas.get_renderer()
    assert legend.get_window_extent(renderer).y1 < fig.axes[0].get_window_extent(renderer).y0


def test_walker_timing_diagram_names_its_lanes_and_keeps_marks_inside():
    t = np.linspace(0.0, 6.0, 200)
    phases = [("phase 1", t, 0.05 * ((t % 3.0) < 1.0)), ("phase 2", t, 0.08 * ((t % 3.0) > 1.5))]
    units = [
        ("purple 1", [(0.2, 1.1), (3.2, 4.1)], "metastable"),
        ("green 1", [], "monostable"),
        ("action 1, flat here", [], "metastable"),
        ("action 2", [], None),
    ]
    marks = [(0.0, "cycle 1"), (3.0, "cycle 2")]
    fig = timing_figure(phases, units, t_end=6.0, marks=marks, title="front leg, walking")
    assert_readable(fig)
    ax = fig.axes[0]
    assert ax.get_ylabel() and [t.get_text() for t in ax.texts] == ["cycle 1", "cycle 2"]


def test_surrogate_speed_error_chart_is_readable():
    speed = [
        {"model": "exact", "us_batched": 3.0, "us_single": 40.0, "tip_p95": 0.0},
        {"model": "knn", "us_batched": 0.8, "us_single": 30.0, "tip_p95": 0.9},
        {"model": "mlp", "us_batched": 1.5, "us_single": 60.0, "tip_p95": 0.2},
        {"model": "gbm", "us_batched": 6.0, "us_single": 90.0, "tip_p95": 0.05},
    ]
    (fig,) = report_figures({"speed": speed, "headline": "tip"}).values()
    assert_readable(fig)
