"""The stable-state figures: one panel per state when there are many, distinct colours when few."""

from __future__ import annotations

import matplotlib
from matplotlib.colors import to_hex
from plotting.figure_checks import assert_readable

from dpfexplore.plotting.statics import plot_states, plot_states_grid
from dpfexplore.solvers.statics import enumerate_states

matplotlib.use("Agg")


def test_many_states_get_a_panel_each(gripper):
    results = enumerate_states(gripper)
    stable = [r for r in results if r.stable]
    fig = plot_states_grid(results)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(stable) > 6 and len(visible) == len(stable)
    assert [ax.get_title() for ax in visible] == [f"state {r.requested}" for r in stable]
    assert_readable(fig)  # the figure states --plot saves for more than six stable states


def test_few_states_get_distinct_colours(gripper):
    results = [r for r in enumerate_states(gripper, which="sequential") if r.stable]
    ax = plot_states(results)
    colours = {to_hex(line.get_color()) for line in ax.get_legend().get_lines()}
    assert len(colours) == len(results)
    assert_readable(ax.figure)
