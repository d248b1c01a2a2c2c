"""Speed against error of surrogates, beside the exact model."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

__all__ = ["plot_speed_error"]


def plot_speed_error(
    speed: pd.DataFrame, *, error: str = "tip_p95", ax: Axes | None = None, unit: str = "mm"
) -> Axes:
    """Time per prediction against held-out error; the exact model as vertical lines.

    Parameters
    ----------
    speed : DataFrame
        Rows ``model``, ``us_batched``, ``us_single`` (µs per prediction) and the ``error``
        column for each surrogate; the row ``model == "exact"`` (error 0) is drawn as two
        vertical lines at its batched and single times. Rows without the error column's value
        (e.g. the classifier) are left out.
    error : str
        Column of the error to plot (log axis).
    ax : Axes, optional
    unit : str
        Unit of the error, for the axis label.
    """
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 4.4))
    rows = (
        speed[(speed["model"] != "exact") & speed[error].notna()]
        if error in speed
        else speed.iloc[:0]
    )
    for _, row in rows.iterrows():
        (line,) = ax.plot(
            [row["us_batched"], row["us_single"]], [row[error]] * 2, "-", lw=0.8, alpha=0.6
        )
        ax.plot(row["us_batched"], row[error], "o", color=line.get_color(), label=f"{row['model']}")
        ax.plot(row["us_single"], row[error], "o", mfc="none", color=line.get_color())
    exact = speed[speed["model"] == "exact"]
    if len(exact):
        ax.axvline(
            float(exact["us_batched"].iloc[0]),
            color="k",
            lw=1.2,
            label="exact model, batched (error 0)",
        )
        ax.axvline(
            float(exact["us_single"].iloc[0]),
            color="k",
            lw=1.2,
            ls="--",
            label="exact model, single",
        )
    ax.set_xscale("log")
    if len(rows) and np.all(rows[error] > 0):
        ax.set_yscale("log")
    ax.set_xlabel("µs per prediction, one core (filled: batched, open: single)")
    ax.set_ylabel(f"held-out {error.replace('_', ' ')} error ({unit})")
    ax.legend(fontsize="small")
    ax.grid(True, which="both", alpha=0.3)
    return ax
