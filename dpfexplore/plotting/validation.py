"""Printed fingers against their predictions: the figure of ``dpfexplore validate --plot``.

One panel per printed finger: the lattice each constants set predicts, drawn in the state its
state search found (limiting layer solid, dome line dashed, posts thin; MODEL.md §5 frame, mm),
its tip a dot, hollow when the measured state does not hold under that set; the measured tip a
black cross, the file's reference tip (the paper's own model) a grey plus. The panel's title
names the finger and gives each set's tip distance to the measured tip (mm), or, for a finger
measured for stiffness only, each set's predicted over measured stiffness.

The functions take the per-finger results of :func:`dpfexplore.measurements.validate`
(:class:`~dpfexplore.measurements.FingerResult`): any objects with the attributes ``finger``,
``material``, ``constants``, ``nodes``, ``holds``, ``measured_tip``, ``reference_tip``,
``distance`` and ``stiffness_ratio``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from .statics import plot_finger

__all__ = ["SET_COLORS", "plot_finger_validation", "plot_validation"]

#: Colour of each set, in the order the sets are given.
SET_COLORS = ("C0", "C3", "C2", "C4", "C1", "C5")
#: Markers of the measured and the reference tip.
MEASURED = {"marker": "X", "color": "k", "ms": 9, "ls": "none", "zorder": 5}
REFERENCE = {"marker": "P", "color": "0.55", "ms": 8, "ls": "none", "zorder": 4}


def _sets(results: Sequence[Any]) -> list[str]:
    names: list[str] = []
    for r in results:
        if r.constants not in names:
            names.append(r.constants)
    return names


def _figures(rows: Sequence[Any]) -> str:
    """Each set's tip distance (mm) or stiffness ratio, for the panel's title."""
    if all(r.distance is not None for r in rows):
        return ", ".join(
            f"{r.constants} {r.distance:.1f} mm" if not math.isnan(r.distance) else r.constants
            for r in rows
        )
    return "K/K meas. " + ", ".join(f"{r.constants} {r.stiffness_ratio:.2f}" for r in rows)


def plot_finger_validation(
    rows: Sequence[Any], ax: Axes | None = None, *, colors: dict[str, str] | None = None
) -> Axes:
    """One printed finger: each set's predicted lattice, the measured tip marked.

    Parameters
    ----------
    rows : sequence of FingerResult
        The finger's results, one per constants set (the same finger).
    ax : Axes, optional
    colors : dict of str to str, optional
        A colour per set name (default: :data:`SET_COLORS` in the order of ``rows``).

    Returns
    -------
    Axes
        Lines labelled with the set names (one limiting layer per set), the measured tip
        labelled ``measured tip``, the reference tip ``reference tip``.
    """
    if not rows or len({r.finger for r in rows}) != 1:
        raise ValueError("rows: need the results of one finger (one per constants set)")
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(4, 4))
    if colors is None:
        colors = dict(zip(_sets(rows), SET_COLORS, strict=False))
    for r in rows:
        nodes = np.asarray(r.nodes, dtype=float)
        if nodes.size == 0 or not np.all(np.isfinite(nodes)):
            continue  # nothing was solved (the set's forms are nonsense for this design)
        color = colors.get(r.constants, "0.3")
        plot_finger(nodes, ax, color=color, label=r.constants)
        if not r.holds:  # hollow tip: the state drawn is not the one measured
            ax.plot(*nodes[-1], "o", ms=7, mfc="white", mec=color, mew=1.5, zorder=3)
    first = rows[0]
    if first.reference_tip is not None:
        ax.plot(*first.reference_tip, label="reference tip", **REFERENCE)
    if first.measured_tip is not None:
        ax.plot(*first.measured_tip, label="measured tip", **MEASURED)
    ax.set_title(f"{first.finger} ({first.material})\n{_figures(rows)}", fontsize="small")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize="small")
    for axis in (
        ax.xaxis,
        ax.yaxis,
    ):  # a narrow panel (a finger that curls high) keeps its labels apart
        axis.set_major_locator(MaxNLocator(nbins=4))
    ax.set_xlabel("x (mm)", fontsize="small")
    ax.set_ylabel("y (mm)", fontsize="small")
    return ax


def plot_validation(results: Sequence[Any], *, ncols: int = 5, width: float = 3.3) -> Figure:
    """Every printed finger of a validation, one panel each (:func:`plot_finger_validation`).

    Parameters
    ----------
    results : sequence of FingerResult
        :attr:`dpfexplore.measurements.Validation.fingers`: every finger under every set.
    ncols : int
        Panels per row.
    width : float
        Inches per panel.

    Returns
    -------
    Figure
        The panels in file order, and one legend for the figure, inside it at the bottom: a
        line per set, the measured and reference tips, the hollow tip of a state not held.
    """
    if not results:
        raise ValueError("results: nothing to draw")
    if ncols < 1:
        raise ValueError(f"ncols = {ncols}: must be >= 1")
    names = _sets(results)
    colors = dict(zip(names, SET_COLORS, strict=False))
    by_finger: dict[str, list[Any]] = {}
    for r in results:
        by_finger.setdefault(r.finger, []).append(r)
    n = len(by_finger)
    columns = min(ncols, n)
    rows = math.ceil(n / columns)
    fig = Figure(figsize=(width * columns, width * rows + 0.8), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False)
    for ax, finger_rows in zip(axes.flat, by_finger.values(), strict=False):
        plot_finger_validation(finger_rows, ax, colors=colors)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    handles = [Line2D([], [], color=colors[name], lw=2, label=name) for name in names]
    handles += [
        Line2D([], [], label="measured tip", **MEASURED),
        Line2D([], [], label="reference tip (the file's model)", **REFERENCE),
        Line2D(
            [],
            [],
            marker="o",
            ms=7,
            mfc="white",
            mec="0.3",
            ls="none",
            label="tip of a state other than measured",
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize="small")
    return fig
