"""What the dynamics figures draw: units and keys in the legends, the no-reset markers explained,
no offset axis that turns integration noise into a slope."""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd

from dpfexplore.plotting.dynamics import plot_reset_map

matplotlib.use("Agg")


def test_reset_map_labels_and_scale():
    frame = pd.DataFrame(
        {
            "value": [0.05, 1.0, 0.05, 1.0],
            "reset_time": [0.032685, 0.0326851, np.inf, np.inf],
            "H": [2.9, 2.9, 3.2, 3.2],
        }
    )
    ax = plot_reset_map(frame, "value", hue="H")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["H = 2.9 mm", "H = 3.2 mm", "no reset within the horizon"]
    ax.figure.canvas.draw()
    assert ax.yaxis.get_major_formatter().get_offset() == ""
    low, high = ax.get_ylim()
    assert high - low > 0.05 * 0.0327  # noise of 1e-7 s is not stretched over the axis


def test_simulation_figure_explains_its_thresholds_and_snaps(pickplace):
    from dpfexplore.plotting.dynamics import plot_extensions
    from dpfexplore.solvers.dynamics.simulate import PressureProfile, simulate

    result = simulate(pickplace, PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1)), t_end=8.0)
    ax = plot_extensions(result)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[: pickplace.n_units] == [
        f"unit {k + 1}" + (f" ({c})" if c else "") for k, c in enumerate(result.unit_class)
    ]
    assert {"inversion threshold", "snap-through", "snap-back"} <= set(labels)
    dotted = [line for line in ax.get_lines() if line.get_linestyle() == ":"]
    assert len(dotted) >= pickplace.n_units  # one threshold per unit
