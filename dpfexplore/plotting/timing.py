"""Figures of the timing scenes: pick-and-place reset map and front, walker gait timing.

Arrays in, Axes out; nothing here writes files.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes

__all__ = ["CLASS_COLOURS", "plot_difference_front", "plot_gait_timing", "plot_reset_screen"]

#: Colour of each unit class in the timing diagrams.
CLASS_COLOURS = {
    "bistable": "tab:blue",
    "metastable": "tab:green",
    "monostable": "tab:orange",
    "no_contact": "tab:gray",
    None: "0.6",
}


#: Height of the band under the screening grid that holds its legend (fraction of the grid's
#: height): two entries at the smallest font.
_LEGEND_BAND = 0.15


def _axes(ax: Axes | None, size=(7, 5)) -> Axes:
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=size)
    return ax


def plot_reset_screen(
    H: np.ndarray,
    t: np.ndarray,
    value: np.ndarray,
    admissible: np.ndarray,
    *,
    designs: Sequence[tuple[float, float, str]] = (),
    ax: Axes | None = None,
    method: str = "",
    h_label: str = "H (mm)",
) -> Axes:
    """Objective reset time over the screening grid (log colour), with designs marked.

    Parameters
    ----------
    H, t : ndarray of shape (n,), mm
        Grid points (the free height and the dome thickness).
    value : ndarray of shape (n,), s
        Objective reset time (``inf``: never resets; NaN: not admissible).
    admissible : ndarray of bool, shape (n,)
    designs : sequence of (H, t, label)
        Reported designs.
    """
    from matplotlib.colors import LogNorm

    ax = _axes(ax)
    finite = admissible & np.isfinite(value) & (value > 0)
    sc = ax.scatter(
        H[finite],
        t[finite],
        c=value[finite],
        s=14,
        marker="s",
        norm=LogNorm(
            vmin=max(1e-2, float(np.min(value[finite])) if finite.any() else 1e-2),
            vmax=max(1.0, float(np.max(value[finite])) if finite.any() else 1.0),
        ),
        cmap="viridis",
    )
    ax.figure.colorbar(sc, ax=ax, label="objective reset time (s)")
    never = admissible & np.isposinf(value)
    ax.scatter(
        H[never],
        t[never],
        s=6,
        marker="s",
        color="tab:blue",
        alpha=0.4,
        label="never resets (bistable)",
    )
    ax.scatter(
        H[~admissible],
        t[~admissible],
        s=4,
        marker="s",
        color="0.8",
        label="not admissible (a hold unit resets, or none inverts)",
    )
    for h, tt, label in designs:
        ax.plot(h, tt, "*", color="tab:red", ms=13, mec="k")
        ax.annotate(label, (h, tt), textcoords="offset points", xytext=(6, 4), fontsize="small")
    ax.axvline(3.0, color="k", lw=0.6, ls="--")
    ax.set_xlabel(h_label + "; dashed: lower end of the fitted range")
    ax.set_ylabel("t (mm)")
    ax.set_title(f"Screening ({method}) and the reported designs (stars)", fontsize="medium")
    # a band under the lowest row of the grid, where the legend stands clear of the points
    low, high = ax.get_ylim()
    ax.set_ylim(low - _LEGEND_BAND * (high - low), high)
    ax.legend(fontsize="x-small", loc="lower left")
    return ax


def plot_difference_front(
    front: Sequence[tuple[float, float, float]],
    *,
    lines: Sequence[tuple[float, float]] = (),
    weighted: tuple[float, float] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """Grasp stiffness against the reset-time difference of two profiles.

    Parameters
    ----------
    front : sequence of (difference s, stiffness N/mm, t mm)
        Non-dominated verified designs.
    lines : sequence of (difference, stiffness)
        Every line optimum (dominated ones included).
    weighted : (difference, stiffness), optional
        The paper's weighted-sum pick.
    """
    ax = _axes(ax, (6, 5))
    if lines:
        d, k = np.array(lines, dtype=float).T
        ax.plot(d, k, "o", color="0.7", label="optimum of one line of t")
    if front:
        d, k, tt = np.array(front, dtype=float).T
        order = np.argsort(d)
        ax.plot(
            d[order], k[order], "-", color="tab:blue", lw=1.2, zorder=2, label="front (verified)"
        )
        # t by colour, not by text: labels of neighbouring points overlapped and were clipped
        dots = ax.scatter(
            d, k, c=tt, cmap="viridis", s=36, edgecolors="k", linewidths=0.5, zorder=3
        )
        colorbar = ax.figure.colorbar(dots, ax=ax)
        colorbar.set_label("t (mm) of the front's designs")
    if weighted is not None:
        ax.plot(*weighted, "*", color="tab:red", ms=14, mec="k", label="weighted sum", zorder=4)
    ax.margins(0.08)
    ax.set_xlabel("RT_2 - RT_1 (s)")
    ax.set_ylabel("grasp stiffness (N/mm)")
    ax.set_title("Two-profile difference against grasp stiffness", fontsize="medium")
    ax.legend(fontsize="small", loc="best")
    return ax


def plot_gait_timing(
    phases: Sequence[tuple[str, np.ndarray, np.ndarray]],
    units: Sequence[tuple[str, Sequence[tuple[float, float]], str | None]],
    *,
    t_end: float,
    marks: Sequence[tuple[float, str]] = (),
    ax: Axes | None = None,
    title: str = "",
) -> Axes:
    """Timing diagram: phase pressures on top, each unit's inverted intervals below.

    Parameters
    ----------
    phases : sequence of (label, t s, P MPa)
        Pressure of each phase.
    units : sequence of (label, intervals, class)
        Each unit's inverted intervals ``(t_start, t_end)`` (s), coloured by class
        (:data:`CLASS_COLOURS`).
    t_end : float, s
    marks : sequence of (t, label)
        Vertical marks (e.g. the start of the next cycle).
    """
    ax = _axes(ax, (10, 1.2 + 0.4 * (len(units) + 2 * len(phases))))
    lane = 0.0
    ticks, labels = [], []
    p_max = max((float(np.max(P)) for _, _, P in phases), default=1.0) or 1.0
    for label, t, P in reversed(phases):
        ax.fill_between(
            t,
            lane,
            lane + 1.6 * np.asarray(P) / p_max,
            step=None,
            alpha=0.35,
            color="tab:purple" if "1" in label else "tab:olive",
        )
        ax.plot(t, lane + 1.6 * np.asarray(P) / p_max, color="k", lw=0.6)
        ticks.append(lane + 0.8)
        labels.append(f"{label} (peak {float(np.max(P)) * 1000:.0f} kPa)")
        lane += 2.0
    for label, intervals, cls in reversed(units):
        for a, b in intervals:
            ax.barh(
                lane + 0.4,
                b - a,
                left=a,
                height=0.7,
                color=CLASS_COLOURS.get(cls, "0.6"),
                edgecolor="k",
                lw=0.4,
            )
        ticks.append(lane + 0.4)
        labels.append(f"{label} ({cls or 'never inverted'})")
        lane += 1.0
    for t, text in marks:
        ax.axvline(t, color="0.4", lw=0.7, ls="--")
        # right of its line: centred on it, the mark at t = 0 would stand half outside the axes
        ax.annotate(
            text,
            (t, lane + 0.1),
            xytext=(2, 0),
            textcoords="offset points",
            fontsize="x-small",
            ha="left",
            va="bottom",
        )
    ax.set_yticks(ticks, labels, fontsize="small")
    ax.set_xlim(0.0, t_end)
    ax.set_ylim(-0.2, lane + 0.6)
    ax.set_xlabel("time (s); bars: unit inverted (colour: its class)")
    ax.set_ylabel("unit (its class); phase (its pressure)")
    if title:
        ax.set_title(title, fontsize="medium")
    return ax
