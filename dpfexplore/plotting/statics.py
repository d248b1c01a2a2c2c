"""Finger shapes at their stable states (the paper's Fig. 3b style)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes

from ..solvers.statics import StateResult

__all__ = ["plot_finger", "plot_states"]


def plot_finger(nodes: np.ndarray, ax: Axes | None = None, *, color=None, label=None) -> Axes:
    """Draw one lattice: dome line, limiting layer and posts.

    Parameters
    ----------
    nodes : ndarray of shape (2N + 2, 2), mm
        Node positions (row ``2k`` is ``D_k``, ``2k + 1`` is ``L_k``).
    ax : Axes, optional
    color, label
        Passed to matplotlib.
    """
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6, 5))
    dome, layer = nodes[0::2], nodes[1::2]
    (line,) = ax.plot(layer[:, 0], layer[:, 1], "-", color=color, lw=2.0, label=label)
    color = line.get_color()
    ax.plot(dome[:, 0], dome[:, 1], "--", color=color, lw=1.0)
    for lower, upper in zip(dome, layer, strict=True):
        ax.plot([lower[0], upper[0]], [lower[1], upper[1]], "-", color=color, lw=0.8)
    ax.plot(*layer[-1], "o", color=color, ms=4)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    return ax


def plot_states(results: Sequence[StateResult], ax: Axes | None = None) -> Axes:
    """Overlay every stable state of a finger (collapsed and failed states are skipped)."""
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(7, 6))
    import matplotlib as mpl

    stable = [r for r in results if r.stable]
    # a qualitative map: neighbouring states must not get near-identical colours
    colors = mpl.colormaps["tab20" if len(stable) > 10 else "tab10"].colors
    for i, result in enumerate(stable):
        plot_finger(result.nodes, ax, color=colors[i % len(colors)], label=result.requested)
    ax.legend(title="state", fontsize="small", ncols=2 if len(stable) > 8 else 1)
    ax.set_title("Stable states (solid: limiting layer, dashed: dome line)")
    return ax


def plot_states_grid(results: Sequence[StateResult]):
    """One small panel per stable state, the rest shape in grey behind each: a Figure.

    Overlaid, more than a handful of states hide each other; side by side with shared axes
    each shape reads on its own.
    """
    from matplotlib.figure import Figure

    stable = [r for r in results if r.stable]
    rest = next((r for r in stable if set(r.requested) <= {"0"}), None)
    columns = min(4, max(len(stable), 1))
    rows = max(1, -(-len(stable) // columns))
    fig = Figure(figsize=(3.0 * columns, 2.6 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, columns, sharex=True, sharey=True)).ravel()
    for ax, result in zip(axes, stable, strict=False):
        if rest is not None and result is not rest:
            plot_finger(rest.nodes, ax, color="0.8")
        plot_finger(result.nodes, ax, color="C0")
        ax.set_title(f"state {result.requested}", fontsize="small")
        ax.set_xlabel("")
        ax.set_ylabel("")
    for ax in axes[len(stable) :]:
        ax.set_visible(False)
    fig.supxlabel("x (mm)")
    fig.supylabel("y (mm)")
    fig.suptitle("Stable states (grey: the rest shape; dashed: dome line)")
    return fig
