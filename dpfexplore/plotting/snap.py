"""Snap sequences: each unit's extension (or the tip) against chamber pressure, snaps marked."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes

from ..solvers.snap.continuation import SnapSequence

__all__ = ["plot_snap"]


def plot_snap(sequence: SnapSequence, ax: Axes | None = None, *, quantity: str = "u") -> Axes:
    """Draw the branches a slow ramp follows, with each snap as a dotted jump.

    Parameters
    ----------
    sequence : SnapSequence
    ax : Axes, optional
    quantity : {"u", "tip"}
        ``"u"``: every unit's dome extension over its reach against pressure (MPa);
        ``"tip"``: the tip's x and y (mm).

    Returns
    -------
    Axes
    """
    if quantity not in ("u", "tip"):
        raise ValueError(f"quantity = {quantity!r}: choose 'u' or 'tip'")
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(7, 4.5))
    path = sequence.path
    if quantity == "u":
        values = path["u"]
        labels = [f"unit {k + 1}" for k in range(values.shape[1])]
        ax.set_ylabel("dome extension u = x̄/d")
    else:
        values = path["tip"]
        labels = ["tip x", "tip y"]
        ax.set_ylabel("tip (mm)")
    pressure = path["P"]
    segments = path["segment"]
    colors = [f"C{k % 10}" for k in range(values.shape[1])]
    for seg in np.unique(segments):
        rows = segments == seg
        for k, color in enumerate(colors):
            ax.plot(
                pressure[rows],
                values[rows, k],
                "-",
                color=color,
                lw=1.4,
                label=labels[k] if seg == segments[0] else None,
            )
    # each snap: a dotted jump from the fold's last point to the landing's first
    for seg in np.unique(segments)[1:]:
        before = np.flatnonzero(segments == seg - 1)
        after = np.flatnonzero(segments == seg)
        if not (before.size and after.size):
            continue
        i, j = before[-1], after[0]
        if not np.isclose(pressure[i], pressure[j], rtol=0.0, atol=1e-9):
            continue  # the turn of a cycle, not a snap
        for k, color in enumerate(colors):
            ax.plot(
                [pressure[i], pressure[j]], [values[i, k], values[j, k]], ":", color=color, lw=1.0
            )
    _label_snaps(ax, sequence.snaps)
    # In a column of panels sharing the pressure axis, the axis label and the title go once:
    # under the bottom panel and over the top one (repeated, they crowd the space between).
    spec = ax.get_subplotspec()
    shared = len(ax.get_shared_x_axes().get_siblings(ax)) > 1
    if not (shared and spec is not None and not spec.is_last_row()):
        ax.set_xlabel("chamber pressure (MPa)")
    title = (
        f"slow ramp ({sequence.direction}), snaps at "
        + ", ".join(f"{e.pressure:.4g}" for e in sequence.snaps)
        + " MPa"
        if sequence.snaps
        else f"slow ramp ({sequence.direction}), no snap"
    )
    if not (shared and spec is not None and not spec.is_first_row()):
        ax.set_title(title, fontsize="small")
    # beside the panel: inside, it hides the snaps that land at the highest pressures
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return ax


#: Headroom above the curves (fraction of their range) where the snaps' state labels stand.
_HEADROOM = 0.22
#: Two labels closer than this (fraction of the pressure range) stand on either side of their
#: lines instead of both on the left.
_CLOSE = 0.03


def _label_snaps(ax: Axes, snaps) -> None:
    """A grey line at each snap and the state it lands in, above the curves, inside the frame.

    The y range grows by :data:`_HEADROOM` so that the labels stand clear of the curves; each
    label is offset from the frame and from its line by a few points, on a white ground, and a
    label close to the one before it goes to the other side of its line.
    """
    if not snaps:
        return
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + _HEADROOM * (high - low))
    x_low, x_high = ax.get_xlim()
    span = max(x_high - x_low, 1e-12)
    previous = None
    left = True
    for event in sorted(snaps, key=lambda e: e.pressure):
        ax.axvline(event.pressure, color="0.6", lw=0.6, zorder=0)
        if previous is not None and (event.pressure - previous) / span < _CLOSE and left:
            left = False
        else:
            left = True
        previous = event.pressure
        ax.annotate(
            event.after or "unsettled",
            (event.pressure, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(-2 if left else 2, -4),
            textcoords="offset points",
            rotation=90,
            va="top",
            ha="right" if left else "left",
            fontsize="x-small",
            color="0.3",
            bbox={"boxstyle": "square,pad=0.1", "facecolor": "white", "edgecolor": "none"},
        )
