"""Plots of simulations, reset-time maps and the dynamics benchmark.

Every function draws on the given Axes (or a new one from :func:`matplotlib.pyplot.subplots`)
and returns it; nothing here writes files or shows windows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "plot_extensions",
    "plot_reset_map",
    "plot_reset_maps",
    "plot_simulation",
    "plot_time_vs_error",
    "plot_tip_and_pressure",
]


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots()
    return ax


def plot_tip_and_pressure(result, ax=None):
    """Tip displacement ``|tip(t) - tip(0)|`` (mm) and pressure (MPa, right axis) against time.

    The paper's Fig. 2c/2d style. Returns the left Axes (the pressure axis is its twin).
    """
    ax = _axes(ax)
    displacement = np.linalg.norm(result.tip - result.tip[0], axis=1)
    ax.plot(result.t, displacement, color="C0", label="tip displacement")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("tip displacement (mm)", color="C0")
    twin = ax.twinx()
    twin.plot(result.t, result.pressure, color="C3", linestyle="--", label="pressure")
    twin.set_ylabel("pressure (MPa)", color="C3")
    twin.set_ylim(bottom=min(0.0, float(np.min(result.pressure))))
    ax.set_title(f"{result.design.name or 'finger'}: state {result.final_state} ({result.method})")
    return ax


def plot_extensions(result, ax=None):
    """Each dome's extension ``u = x̄/d`` against time, thresholds dashed, snaps marked."""
    from ..solvers.lattice import spring_constants

    ax = _axes(ax)
    thresholds = spring_constants(result.design).domes.u_inversion
    for k in range(result.design.n_units):
        color = f"C{k % 10}"
        label = f"unit {k + 1}"
        if result.unit_class[k]:
            label += f" ({result.unit_class[k]})"
        ax.plot(result.t, result.extensions[:, k], color=color, label=label)
        ax.axhline(thresholds[k], color=color, linestyle=":", linewidth=0.8)
        for when, marker in ((result.snap_through[k], "^"), (result.snap_back[k], "v")):
            if np.isfinite(when):
                ax.plot([when], [thresholds[k]], marker=marker, color=color, linestyle="none")
    # one legend entry for what the dotted lines and the triangles mean (they share the colours)
    ax.plot([], [], color="0.4", linestyle=":", linewidth=0.8, label="inversion threshold")
    ax.plot([], [], color="0.4", marker="^", linestyle="none", label="snap-through")
    ax.plot([], [], color="0.4", marker="v", linestyle="none", label="snap-back")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("dome extension x̄/d")
    # beside the axes: the curves fill the panel (a snap-back crosses every height), so no
    # corner inside it is free of data
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return ax


def plot_simulation(result, axes: Sequence[Any] | None = None):
    """Tip/pressure above, extensions below (two Axes, created if not given)."""
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 7))
    plot_tip_and_pressure(result, axes[0])
    plot_extensions(result, axes[1])
    return axes


def plot_reset_map(frame, x: str, *, hue: str | None = None, ax=None, xlabel: str | None = None):
    """Reset time against one parameter, one line per value of ``hue``.

    ``frame`` holds the columns ``x``, ``reset_time`` (s after the end of the release ramp,
    ``τ4``; ``inf`` = never resets within the horizon) and optionally ``hue``. A unit that never
    resets has no time to draw: it is an open triangle on the top edge of the axes, outside the
    time scale. A negative time is a unit that snapped back during the release ramp, before the
    pressure reached zero at ``τ4`` (MODEL.md §8 counts reset times from ``τ4``); the zero line
    is then drawn and named.
    """
    ax = _axes(ax)
    groups = [(None, frame)] if hue is None else list(frame.groupby(hue, sort=True))
    unit = _UNITS.get(hue or "", "")
    edge = ax.get_xaxis_transform()  # x in data, y in axes fractions: 1 is the top edge
    for i, (value, group) in enumerate(groups):
        color = f"C{i % 10}"
        label = None if hue is None else f"{hue} = {value:g}{unit}"
        finite = np.isfinite(group["reset_time"])
        ax.plot(group[x][finite], group["reset_time"][finite], marker="o", color=color, label=label)
        never = np.isinf(group["reset_time"])
        if never.any():
            ax.plot(
                group[x][never],
                np.ones(never.sum()),
                marker="^",
                color=color,
                markerfacecolor="none",
                linestyle="none",
                transform=edge,
                clip_on=False,
            )
    if np.isinf(frame["reset_time"]).any():
        ax.plot(
            [],
            [],
            marker="^",
            markerfacecolor="none",
            color="0.3",
            linestyle="none",
            label="no reset within the horizon",
        )
    finite = frame["reset_time"][np.isfinite(frame["reset_time"])]
    if len(finite) and float(finite.min()) < 0.0:
        ax.axhline(0.0, color="0.5", linestyle="--", linewidth=0.8)
        ax.plot(
            [],
            [],
            color="0.5",
            linestyle="--",
            linewidth=0.8,
            label="end of release (τ4);\nbelow: reset during the ramp",
        )
    if len(finite) and np.ptp(finite) < 1e-3 * max(abs(float(finite.mean())), 1e-12):
        # equal up to integration noise: a span of ±5 % keeps that noise from reading as a trend
        centre = float(finite.mean())
        ax.set_ylim(sorted((0.95 * centre, 1.05 * centre)))
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    ax.set_xlabel(xlabel or x)
    ax.set_ylabel("reset time after release (s)")
    if ax.get_legend_handles_labels()[1]:
        # below the axes: the lines may cross any corner of the panel
        ax.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.16))
    return ax


#: Units of the parameters a reset map may be drawn against (legend labels).
_UNITS = {"H": " mm", "t": " mm", "U_L": " mm", "U_sep": " mm", "hold": " s"}


def plot_time_vs_error(records: Sequence[dict], ax=None, *, case: str | None = None):
    """Benchmark records: time per reset-time evaluation against its error (log-log)."""
    ax = _axes(ax)
    for i, rec in enumerate(r for r in records if case is None or r.get("case") == case):
        err = max(float(rec["reset_time_rel_err"]), 1e-9)
        ax.loglog(
            [rec["us_per_design"]],
            [err],
            marker="o",
            linestyle="none",
            color=f"C{i % 10}",
            label=rec["method"],
        )
    ax.set_xlabel("time per design (µs)")
    ax.set_ylabel("reset time relative error")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    if case:
        ax.set_title(case)
    return ax


def plot_reset_maps(maps, fig=None):
    """The three maps of :func:`dpfexplore.solvers.dynamics.resetmaps.reset_time_maps` side by side.

    ``maps`` holds the ``"H"``, ``"t"`` and ``"hold"`` frames. Draws on ``fig`` (a new
    :class:`matplotlib.figure.Figure` by default) and returns it.
    """
    from matplotlib.figure import Figure

    if fig is None:
        fig = Figure(figsize=(13, 5), layout="constrained")
    axes = fig.subplots(1, 3)
    labels = {"H": "dome height H (mm)", "t": "dome thickness t (mm)", "hold": "hold time (s)"}
    for ax, name in zip(axes, ("H", "t", "hold"), strict=True):
        frame = maps[name]
        if name == "hold":
            if frame["n_units"].iloc[0] > 1:
                # one curve per height: the last of the finger's units to reset
                finite = frame[np.isfinite(frame["reset_time"])]
                frame = finite.groupby(["H", "value"], as_index=False)["reset_time"].max()
                frame["n_units"] = maps[name]["n_units"].iloc[0]
                frame["t"] = maps[name]["t"].iloc[0]
                frame["horizon"] = maps[name]["horizon"].iloc[0]
            plot_reset_map(frame, "value", hue="H", ax=ax, xlabel=labels[name])
            ax.set_xscale("log")
            if frame["n_units"].iloc[0] > 1:
                ax.set_ylabel("last unit's reset time after release (s)")
        else:
            hue = "unit" if frame["n_units"].iloc[0] > 1 else None
            plot_reset_map(frame, "value", hue=hue, ax=ax, xlabel=labels[name])
        fixed = {
            "H": f"t = {frame['t'].iloc[0]:g} mm",
            "t": f"H = {frame['H'].iloc[0]:g} mm",
            "hold": f"t = {frame['t'].iloc[0]:g} mm",
        }[name]
        horizon = frame["horizon"].iloc[0]
        ax.set_title(f"{fixed}, N = {frame['n_units'].iloc[0]} (horizon {horizon:g} s)")
    return fig
