"""The tip region a dataset reaches, per number of units, with a lookup's target and designs.

:func:`plot_reachable` draws, for each ``N``, the outline of the cloud of tip positions (the
boundary of the occupied cells of a 2-D histogram, gaps of one cell closed, so a sparse cloud
stays one region and a real hole in a dense one stays a hole), the points themselves faintly, the
target and the candidates' tips. Input is plain arrays (see
:func:`dpfexplore.lookup.query.reachable_tips`); no file I/O.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike, NDArray

__all__ = ["occupied_cells", "plot_reachable"]

#: Points drawn per N at most (a random subset; the outline uses every point).
_MAX_POINTS = 4000


def occupied_cells(
    tips: NDArray, x_edges: NDArray, y_edges: NDArray, *, min_share: float = 0.005
) -> NDArray[np.bool_]:
    """Cells of the grid ``x_edges`` x ``y_edges`` that outline a tip cloud.

    The cells holding a tip, with gaps of one cell closed; connected groups of cells holding
    fewer than ``min_share`` of the points (stray designs far from the cloud) are left out of
    the outline (their points are still drawn). Returns an array of shape
    ``(len(x_edges) - 1, len(y_edges) - 1)``.
    """
    from scipy import ndimage

    counts, _, _ = np.histogram2d(tips[:, 0], tips[:, 1], bins=(x_edges, y_edges))
    occupied = counts > 0
    closed = ndimage.binary_closing(occupied, structure=np.ones((3, 3)), border_value=0)
    closed |= occupied
    labels, n_groups = ndimage.label(closed, structure=np.ones((3, 3)))
    if n_groups <= 1:
        return closed
    points = ndimage.sum_labels(counts, labels, index=np.arange(1, n_groups + 1))
    keep = np.flatnonzero(points >= min_share * max(len(tips), 1)) + 1
    return np.isin(labels, keep)


def plot_reachable(
    tips_by_n: Mapping[int, ArrayLike],
    target: Sequence[float] | None = None,
    candidates: Sequence[Sequence[float]] = (),
    *,
    labels: Sequence[str] | None = None,
    bins: int = 120,
    ax: Axes | None = None,
) -> Axes:
    """Reachable tip region per N, the target (a star) and the candidates' tips (dots).

    Parameters
    ----------
    tips_by_n : mapping of int to array_like of shape (m, 2), mm
        Tip positions of the dataset's usable rows, per number of units.
    target : (x, y), mm, optional
    candidates : sequence of (x, y), mm
        Tips of the reported designs, best first (the best is ringed).
    labels : sequence of str, optional
        One label per candidate (e.g. its status), shown in the legend for the best.
    bins : int
        Histogram cells along the longer side of the plotted extent.
    ax : Axes, optional
    """
    if ax is None:
        import matplotlib.pyplot as plt

        # constrained: the legend beside the axes stays inside the figure
        _, ax = plt.subplots(figsize=(6.5, 5.5), layout="constrained")
    import matplotlib as mpl

    clouds = {int(n): np.asarray(t, dtype=float).reshape(-1, 2) for n, t in tips_by_n.items()}
    clouds = {n: t for n, t in clouds.items() if len(t)}
    extra = [np.asarray(target, float).reshape(1, 2)] if target is not None else []
    extra += [np.asarray(candidates, float).reshape(-1, 2)] if len(candidates) else []
    every = np.concatenate([*clouds.values(), *extra]) if clouds or extra else np.zeros((1, 2))
    low, high = every.min(axis=0), every.max(axis=0)
    span = max(float(np.max(high - low)), 1.0)
    cell = span / bins
    low, high = low - 2 * cell, high + 2 * cell
    x_edges = np.arange(low[0], high[0] + cell, cell)
    y_edges = np.arange(low[1], high[1] + cell, cell)
    centres = (0.5 * (x_edges[1:] + x_edges[:-1]), 0.5 * (y_edges[1:] + y_edges[:-1]))
    cmap = mpl.colormaps["viridis"]
    span_n = max(len(clouds) - 1, 1)
    rng = np.random.default_rng(0)
    handles = []
    for i, (n, tips) in enumerate(sorted(clouds.items())):
        colour = cmap(0.9 * i / span_n)
        shown = (
            tips
            if len(tips) <= _MAX_POINTS
            else tips[rng.choice(len(tips), _MAX_POINTS, replace=False)]
        )
        ax.scatter(
            shown[:, 0], shown[:, 1], s=1, color=colour, alpha=0.25, linewidths=0, rasterized=True
        )
        occupied = occupied_cells(tips, x_edges, y_edges).astype(float)
        if occupied.any():
            ax.contour(
                centres[0], centres[1], occupied.T, levels=[0.5], colors=[colour], linewidths=1.2
            )
        handles.append(mpl.lines.Line2D([], [], color=colour, label=f"N = {n}"))
    if len(candidates):
        tips = np.asarray(candidates, float).reshape(-1, 2)
        ax.scatter(tips[:, 0], tips[:, 1], s=14, color="black", zorder=4)
        ax.scatter(
            tips[:1, 0],
            tips[:1, 1],
            s=80,
            facecolors="none",
            edgecolors="red",
            linewidths=1.5,
            zorder=5,
        )
        best = "best design" + (f" ({labels[0]})" if labels else "")
        handles.append(
            mpl.lines.Line2D([], [], ls="", marker="o", mfc="none", mec="red", label=best)
        )
        handles.append(
            mpl.lines.Line2D(
                [], [], ls="", marker="o", color="black", ms=4, label="reported designs' tips"
            )
        )
    if target is not None:
        ax.scatter(
            [target[0]], [target[1]], marker="*", s=160, color="red", zorder=6, clip_on=False
        )
        label = f"target ({target[0]:g}, {target[1]:g})"
        handles.append(mpl.lines.Line2D([], [], ls="", marker="*", color="red", ms=10, label=label))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("tip x (mm)")
    ax.set_ylabel("tip y (mm)")
    # Explicit limits: contour sets sticky edges at its grid, which would stop margins from
    # making room for a target at the edge of the extent.
    pad = 0.06 * span
    ax.set_xlim(float(low[0] - pad), float(high[0] + pad))
    ax.set_ylim(float(low[1] - pad), float(high[1] + pad))
    ax.set_title("Tip region the dataset reaches, per N")
    if handles:
        ax.legend(handles=handles, fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return ax
