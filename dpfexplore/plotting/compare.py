"""Two constants sets on whole fingers: the model-uncertainty figure of ``identify compare``.

One column per design, three panels each: the tips of the ``N+1`` sequential states under each
set (in mm, connected in the order the set inverts its units, the undeformed tip marked), the
tip stiffness of those states, and each unit's reset time after the paper's pulse, with the
units still inverted at the run's horizon (``inf``: they stay inverted, or reset later) and those
without a reset (NaN: no contact, never inverted) on rows of their own above and below the
finite times.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

__all__ = ["plot_set_comparison", "sequence_of"]

#: Per set (in the order given): colour, marker, line style.
_STYLES = (("C0", "o", "-"), ("C3", "s", "--"), ("C2", "^", ":"), ("C4", "D", "-."))
#: Tick labels of the rows the reset panel keeps for units without a finite reset time.
INF_LABEL = "inf: inverted\nat the horizon"
NAN_LABEL = "NaN: no contact /\nnot inverted"


def sequence_of(states: pd.DataFrame, name: str) -> pd.DataFrame:
    """One set's sequential states in its own order: ``step``, ``state``, ``found``, ``tip_x``, ...

    The rows of :func:`~dpfexplore.identification.compare.compare_fingers` merge the sets'
    sequences by requested state; a set's own sequence is the rows it solved, its step ``k``
    the state that requests ``k`` inverted units.
    """
    solved = states[f"{name}:found"].notna()
    rows = states[solved]
    steps = rows["state"].map(lambda s: s.count("1"))
    frame = pd.DataFrame(
        {
            "step": steps.to_numpy(int),
            "state": rows["state"].to_numpy(),
            "found": rows[f"{name}:found"].to_numpy(),
            "tip_x": rows[f"{name}:tip_x"].to_numpy(float),
            "tip_y": rows[f"{name}:tip_y"].to_numpy(float),
            "stiffness": rows[f"{name}:stiffness"].to_numpy(float),
        }
    )
    return frame.sort_values("step", kind="stable").reset_index(drop=True)


def plot_set_comparison(
    fingers: Sequence[tuple[str, pd.DataFrame, pd.DataFrame]],
    names: Sequence[str],
    *,
    width: float = 4.2,
) -> Figure:
    """Draw the sets' answers for each design side by side: a Figure, one column per design.

    Parameters
    ----------
    fingers : sequence of (str, DataFrame, DataFrame)
        Per design its title and the ``states`` and ``resets`` tables of
        :func:`~dpfexplore.identification.compare.compare_fingers`.
    names : sequence of str
        The sets' names (the tables' column prefixes), in the order to draw them.
    width : float, optional
        Inches per column.

    Returns
    -------
    Figure
        Rows: tips (``x``, ``y`` in mm), tip stiffness (N/mm) against the sequential step,
        reset time (s) per unit. Every panel has one line per set, labelled with its name;
        hollow markers are states whose solve landed elsewhere than requested.
    """
    if not fingers:
        raise ValueError("fingers: need at least one design")
    if not 1 <= len(names) <= len(_STYLES):
        raise ValueError(f"names: need 1 to {len(_STYLES)} sets, got {len(names)}")
    columns = len(fingers)
    fig = Figure(figsize=(width * columns + 0.6, 10.0), layout="constrained")
    axes = fig.subplots(3, columns, squeeze=False)
    reset_rows = _reset_rows(fingers, names)
    for column, (title, states, resets) in enumerate(fingers):
        tips, stiffness, reset = axes[:, column]
        sequences = [sequence_of(states, name) for name in names]
        _draw_tips(tips, sequences, names)
        n_units = len(resets)
        tips.set_title(f"{title} ({n_units} units)\n{_shift_line(sequences)}", fontsize="medium")
        _draw_stiffness(stiffness, sequences, names, n_units)
        _draw_resets(reset, resets, names, reset_rows, first=column == 0)
    handles = [
        Line2D([], [], color=c, marker=m, ls=ls, label=name)
        for name, (c, m, ls) in zip(names, _STYLES, strict=False)
    ]
    handles.append(Line2D([], [], color="k", marker="*", ls="none", ms=12, label="undeformed tip"))
    handles.append(
        Line2D(
            [], [], color="0.3", marker="o", mfc="white", ls="none", label="solve landed elsewhere"
        )
    )
    # one row of keys where the columns leave room; two keys a row per column of panels else,
    # so a one-design figure keeps its legend inside the page
    ncols = min(len(handles), 2 * columns)
    fig.legend(handles=handles, loc="outside upper center", ncols=ncols, fontsize="small")
    return fig


def _shift_line(sequences: Sequence[pd.DataFrame]) -> str:
    """The tip shift between the first two sets at the last step (every unit requested)."""
    if len(sequences) < 2 or sequences[0].empty or sequences[1].empty:
        return ""
    a, b = sequences[0].iloc[-1], sequences[1].iloc[-1]
    shift = float(np.hypot(a["tip_x"] - b["tip_x"], a["tip_y"] - b["tip_y"]))
    return f"tips at the last step {shift:.3g} mm apart"


def _plot_sequences(
    ax: Axes, sequences: Sequence[pd.DataFrame], names: Sequence[str], x: str, y: str
) -> None:
    """One line per set through its sequence's ``x`` and ``y`` columns, unheld states hollow."""
    for i, (sequence, name) in enumerate(zip(sequences, names, strict=True)):
        color, marker, style = _STYLES[i]
        ax.plot(sequence[x], sequence[y], ls=style, marker=marker, color=color, ms=5, label=name)
        _hollow(ax, sequence, sequence[x], sequence[y], color, marker)


def _draw_tips(ax: Axes, sequences: Sequence[pd.DataFrame], names: Sequence[str]) -> None:
    _plot_sequences(ax, sequences, names, "tip_x", "tip_y")
    undeformed = [s[s["step"] == 0] for s in sequences]
    undeformed = [s for s in undeformed if not s.empty]
    if undeformed:
        ax.scatter(
            undeformed[0]["tip_x"],
            undeformed[0]["tip_y"],
            marker="*",
            s=260,
            color="k",
            zorder=1.5,  # under the sets' markers, which stay visible on it
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.12)
    ax.set_xlabel("tip x (mm)")
    ax.set_ylabel("tip y (mm)")
    ax.grid(alpha=0.3)


def _draw_stiffness(
    ax: Axes, sequences: Sequence[pd.DataFrame], names: Sequence[str], n_units: int
) -> None:
    _plot_sequences(ax, sequences, names, "step", "stiffness")
    ax.set_xticks(range(n_units + 1))
    ax.set_xlabel("sequential step (units requested inverted)")
    ax.set_ylabel("tip stiffness (N/mm)")
    ax.grid(alpha=0.3)


def _hollow(ax: Axes, sequence: pd.DataFrame, x, y, color, marker) -> None:
    """White-filled markers over the states whose solve found another state than requested."""
    moved = (sequence["found"] != sequence["state"]).to_numpy()
    if moved.any():
        ax.scatter(
            np.asarray(x)[moved],
            np.asarray(y)[moved],
            marker=marker,
            s=30,
            facecolor="white",
            edgecolor=color,
            zorder=3,
        )


def _reset_rows(fingers, names) -> dict[str, object]:
    """Where the reset panels draw ``inf`` and NaN: one y axis for every design."""
    values = np.concatenate(
        [resets[f"{name}:reset_time"].to_numpy(float) for _, _, resets in fingers for name in names]
    )
    finite = values[np.isfinite(values)]
    low = min(0.0, float(finite.min())) if finite.size else 0.0
    high = float(finite.max()) if finite.size else 1.0
    if high <= low:
        high = low + 1.0
    ticks = MaxNLocator(nbins=5).tick_values(low, high)
    ticks = [float(t) for t in ticks if low - 1e-12 <= t <= high * (1 + 1e-9)]
    span = high - low
    return {
        "low": low,
        "high": high,
        "inf": high + 0.22 * span,
        "nan": low - 0.22 * span,
        "ticks": ticks,
    }


def _draw_resets(
    ax: Axes, resets: pd.DataFrame, names: Sequence[str], rows: dict, *, first: bool
) -> None:
    units = resets["unit"].to_numpy(float)
    offsets = np.linspace(-0.12, 0.12, len(names)) if len(names) > 1 else [0.0]
    for i, name in enumerate(names):
        color, marker, _ = _STYLES[i]
        times = resets[f"{name}:reset_time"].to_numpy(float)
        shown = np.where(np.isnan(times), rows["nan"], times)
        shown = np.where(np.isinf(shown), rows["inf"], shown)
        ax.plot(units + offsets[i], shown, ls="none", marker=marker, color=color, ms=6, label=name)
    band = 0.05 * (rows["high"] - rows["low"])
    for level in (rows["inf"], rows["nan"]):  # a grey band behind each row (a patch, no line)
        ax.axhspan(level - band, level + band, color="0.9", zorder=0)
    ax.set_ylim(
        rows["nan"] - 0.1 * (rows["high"] - rows["low"]),
        rows["inf"] + 0.1 * (rows["high"] - rows["low"]),
    )
    ticks = [*rows["ticks"], rows["inf"], rows["nan"]]
    labels = [f"{t:g}" for t in rows["ticks"]] + [INF_LABEL, NAN_LABEL]
    ax.set_yticks(ticks, labels=labels if first else [""] * len(ticks), fontsize="small")
    ax.set_xticks(resets["unit"].to_numpy(int))
    ax.set_xlim(units.min() - 0.5, units.max() + 0.5)
    ax.set_xlabel("unit")
    ax.set_ylabel("reset time (s)")
    ax.grid(axis="y", alpha=0.3)
