"""Design-space maps of a sweep (the paper's Fig. S "Exploration of the design space").

The paper samples each number of units N with a Latin hypercube and shows, for the state with
every unit inverted, (a) where the tip goes, (b) the curvature and (c) the stiffness reached.
Its figure file is not in the paper's source, so the panels here are our reading of its caption:
(a) tip positions in the finger frame of MODEL.md §5, one colour per N; (b) and (c) the
distribution of curvature and tip stiffness per N (violins with the points over them).

Every function takes the rows of a sweep dataset (a :class:`pandas.DataFrame` from
:func:`dpfexplore.sweep.storage.store.read_results`), keeps the converged all-inverted rows
(:func:`all_inverted_rows`), and draws on a given or new Axes; no file I/O, no ``plt.show()``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

__all__ = [
    "SPACE_COLUMNS",
    "all_inverted_rows",
    "plot_curvature",
    "plot_design_space",
    "plot_stiffness",
    "plot_tip_positions",
]

#: Columns the maps read (``stiffness`` only when the sweep computed it).
SPACE_COLUMNS = ("n_units", "requested", "status", "tip_x", "tip_y", "curvature", "stiffness")


def all_inverted_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """Rows of the all-inverted state (``requested == 2^N - 1``) that converged (status ok)."""
    for name in ("n_units", "requested", "status"):
        if name not in frame:
            raise ValueError(f"the rows have no column {name!r} (not a statics sweep?)")
    n_units = frame["n_units"].astype(np.int64)
    keep = (frame["requested"] == (2**n_units - 1)) & (frame["status"] == 0)
    return frame.loc[keep]


def _colours(n_values):
    import matplotlib as mpl

    cmap = mpl.colormaps["viridis"]
    span = max(len(n_values) - 1, 1)
    return {n: cmap(0.9 * i / span) for i, n in enumerate(n_values)}


def _axes(ax: Axes | None, size=(5.0, 4.5)) -> Axes:
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=size)
    return ax


def plot_tip_positions(frame: pd.DataFrame, ax: Axes | None = None) -> Axes:
    """Tip positions ``(tip_x, tip_y)`` (mm) of the all-inverted state, coloured by N."""
    ax = _axes(ax)
    rows = all_inverted_rows(frame)
    n_values = sorted(rows["n_units"].unique())
    colours = _colours(n_values)
    for n in n_values:
        part = rows[rows["n_units"] == n]
        ax.scatter(
            part["tip_x"],
            part["tip_y"],
            s=2,
            color=colours[n],
            label=f"N = {n}",
            rasterized=True,
            linewidths=0,
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("tip x (mm)")
    ax.set_ylabel("tip y (mm)")
    ax.set_title("a) Tip position")
    if n_values:
        ax.legend(markerscale=4, fontsize="small")
    return ax


def _violins(rows: pd.DataFrame, name: str, ax: Axes, *, log: bool) -> Axes:
    n_values = sorted(rows["n_units"].unique())
    colours = _colours(n_values)
    data = []
    for n in n_values:
        values = rows.loc[rows["n_units"] == n, name].to_numpy(dtype=float)
        values = values[np.isfinite(values) & ((values > 0) if log else True)]
        data.append(np.log10(values) if log else values)
    positions = [n for n, d in zip(n_values, data, strict=True) if d.size > 1]
    shown = [d for d in data if d.size > 1]
    if shown:
        parts = ax.violinplot(shown, positions=positions, widths=0.8, showextrema=False)
        for body, n in zip(parts["bodies"], positions, strict=True):
            body.set_facecolor(colours[n])
            body.set_alpha(0.35)
    rng = np.random.default_rng(0)  # jitter only; fixed so the figure is reproducible
    for n, values in zip(n_values, data, strict=True):
        jitter = rng.uniform(-0.25, 0.25, values.size)
        ax.scatter(n + jitter, values, s=1, color=colours[n], rasterized=True, linewidths=0)
    ax.set_xticks(n_values)
    ax.set_xlabel("number of units N")
    return ax


def plot_curvature(frame: pd.DataFrame, ax: Axes | None = None) -> Axes:
    """Mean curvature (1/mm) of the all-inverted state per N."""
    ax = _axes(ax)
    _violins(all_inverted_rows(frame), "curvature", ax, log=False)
    ax.set_ylabel("curvature (1/mm)")
    ax.set_title("b) Curvature")
    return ax


def plot_stiffness(frame: pd.DataFrame, ax: Axes | None = None) -> Axes:
    """Tip stiffness (N/mm, log scale) of the all-inverted state per N.

    Raises
    ------
    ValueError
        If the rows have no ``stiffness`` column (the job did not compute it).
    """
    if "stiffness" not in frame:
        raise ValueError("no stiffness column: the sweep did not compute stiffness")
    ax = _axes(ax)
    _violins(all_inverted_rows(frame), "stiffness", ax, log=True)
    ax.set_ylabel("log10 stiffness (N/mm)")
    ax.set_title("c) Stiffness")
    return ax


def plot_design_space(frame: pd.DataFrame, axes=None) -> np.ndarray:
    """The three maps side by side (the stiffness panel only if the sweep computed it).

    Parameters
    ----------
    frame : DataFrame
        Sweep rows with at least ``n_units``, ``requested``, ``status``, ``tip_x``, ``tip_y``,
        ``curvature`` (and ``stiffness``).
    axes : sequence of Axes, optional
        One per panel.

    Returns
    -------
    ndarray of Axes
    """
    panels = [plot_tip_positions, plot_curvature]
    if "stiffness" in frame:
        panels.append(plot_stiffness)
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(
            1, len(panels), figsize=(5.0 * len(panels), 4.5), layout="constrained"
        )
    axes = np.atleast_1d(axes)
    if len(axes) != len(panels):
        raise ValueError(f"axes: need {len(panels)} Axes, got {len(axes)}")
    for panel, ax in zip(panels, axes, strict=True):
        panel(frame, ax)
    return axes
