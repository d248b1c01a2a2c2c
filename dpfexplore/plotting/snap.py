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
    for event in sequence.snaps:
        ax.axvline(event.pressure, color="0.6", lw=0.6, zorder=0)
        ax.annotate(
            event.after,
            (event.pressure, 1.0),
            xycoords=("data", "axes fraction"),
            rotation=90,
            va="top",
            ha="right",
            fontsize="x-small",
            color="0.3",
        )
    ax.set_xlabel("chamber pressure (MPa)")
    title = (
        f"slow ramp ({sequence.direction}), snaps at "
        + ", ".join(f"{e.pressure:.4g}" for e in sequence.snaps)
        + " MPa"
        if sequence.snaps
        else f"slow ramp ({sequence.direction}), no snap"
    )
    ax.set_title(title, fontsize="small")
    ax.legend(fontsize="small")
    return ax
