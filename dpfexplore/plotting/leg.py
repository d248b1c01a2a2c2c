"""Plots of legs (MODEL.md §10): the tip path in two projections.

Every function draws on the given Axes (created if not given) and returns them; nothing here
writes files or shows windows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["PROJECTIONS", "plot_tip_paths"]

#: The two views: the plane of the first sections (x-y, seen from +z) and the implementation's
#: view of the tip path (y-z, seen from +x: MATLAB's ``view(90, 0)``).
PROJECTIONS = ((0, 1), (1, 2))
_AXIS = "xyz"


def plot_tip_paths(
    results: Any, axes: Sequence[Any] | None = None, labels: Sequence[str] | None = None
):
    """Tip paths relative to their start (mm), in the x-y and y-z projections.

    Parameters
    ----------
    results : LegResult or sequence of LegResult
        :func:`dpfexplore.solvers.legs.leg.simulate_leg` outputs, drawn over each other.
    axes : sequence of two Axes, optional
    labels : sequence of str, optional
        One per result (default: the leg names).

    Returns
    -------
    sequence of two Axes
    """
    if not isinstance(results, (list, tuple)):
        results = [results]
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, 2, figsize=(11, 5), layout="constrained")
    labels = labels or [r.leg.name or f"leg {i + 1}" for i, r in enumerate(results)]
    for ax, (a, b) in zip(axes, PROJECTIONS, strict=True):
        for i, (result, label) in enumerate(zip(results, labels, strict=True)):
            path = result.tip_path
            text = label if result.fitted_range else f"{label} (outside fitted H/t/E)"
            ax.plot(path[:, a], path[:, b], color=f"C{i % 10}", label=text)
            ax.plot(path[-1:, a], path[-1:, b], marker="s", color=f"C{i % 10}", linestyle="none")
        ax.plot([0.0], [0.0], marker="o", color="k", linestyle="none", label="start")
        ax.set_xlabel(f"tip {_AXIS[a]} (mm)")
        ax.set_ylabel(f"tip {_AXIS[b]} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.set_title(f"{_AXIS[a]}-{_AXIS[b]} projection (square: end)")
    # under the first projection, below its axis label: inside, it hides the paths' loops
    axes[0].legend(
        fontsize="x-small",
        loc="upper center",
        bbox_to_anchor=(0.5, 0.0),
        bbox_transform=axes[0].transAxes + _below_axis_label(axes[0].figure),
    )
    return axes


def _below_axis_label(figure):
    """A shift down by the height of an x axis's ticks, tick labels and label (points)."""
    import matplotlib as mpl
    from matplotlib.font_manager import FontProperties
    from matplotlib.transforms import ScaledTranslation

    rc = mpl.rcParams
    sizes = [
        FontProperties(size=rc["xtick.labelsize"]).get_size_in_points(),
        FontProperties(size=rc["axes.labelsize"]).get_size_in_points(),
    ]
    drop = sum(sizes) * 1.25 + rc["xtick.major.size"] + rc["xtick.major.pad"] + rc["axes.labelpad"]
    return ScaledTranslation(0.0, -drop / 72.0, figure.dpi_scale_trans)
