"""Figures of one unit-cell run: force and energy against apex travel, deformed meridians.

``plot_*(run, ax=None) -> Axes``: no file I/O, no ``plt.show()`` (the project's plotting
convention); stable stretches solid, unstable ones dashed, one colour per branch (the same
colour for a branch's meridians), each legend beside its axes where it hides no curve.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..model.constants import dome_energy, dome_force
from .shell import UnitCellRun

__all__ = ["plot_energy", "plot_force", "plot_meridians"]


def _axes(ax):
    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(6, 4), layout="constrained").subplots()
    return ax


def _branch_colour(key: int) -> str:
    return f"C{int(key) % 10}"


def _legend_beside(ax) -> None:
    """The axes' legend to its right (a curve may pass through any corner inside it)."""
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _branch_keys(run: UnitCellRun, ax) -> None:
    """Legend entries of the branch colours and of the line styles (the curves carry none)."""
    for key in np.unique(run.branch):
        ax.plot([], [], "-", color=_branch_colour(key), lw=1.2, label=f"branch {key}")
    ax.plot([], [], "-", color="0.4", lw=1.2, label="stable")
    ax.plot([], [], "--", color="0.4", lw=1.2, label="unstable")


def _by_branch(run: UnitCellRun, values, ax) -> None:
    for key in np.unique(run.branch):
        on = np.flatnonzero(run.branch == key)
        # include the next point so the pieces join
        piece = np.append(on, on[-1] + 1) if on[-1] + 1 < run.n_steps else on
        x, y, stable = run.displacement[piece], values[piece], run.stable[piece]
        for flag, style in ((True, "-"), (False, "--")):
            masked = np.where(stable == flag, y, np.nan)
            ax.plot(x, masked, style, color=_branch_colour(key), lw=1.2)


def plot_force(run: UnitCellRun, ax=None, *, spring: tuple[float, float, float] | None = None):
    """Apex reaction (N) against apex travel (mm), by branch; ``spring = (k_b, α, d)`` drawn too.

    The spring law's force is drawn against the apex travel taken as its extension. The
    zero-force states are marked on the axis: a disc where the shell rests stably (the inverted
    rest, ``tip_dis``), a cross where it is in equilibrium but unstable.
    """
    ax = _axes(ax)
    _by_branch(run, run.force, ax)
    _branch_keys(run, ax)
    if spring is not None:
        x = np.linspace(0.0, run.displacement.max(), 300)
        ax.plot(x, dome_force(x, *spring), "k:", lw=1.5, label="fitted spring law")
    marks = {True: ("o", "zero force, stable"), False: ("x", "zero force, unstable")}
    for stable in (True, False):
        at = [s.displacement for s in run.zero_force_states if s.stable == stable]
        if at:
            marker, label = marks[stable]
            ax.plot(at, np.zeros(len(at)), marker, color="k", ms=5, ls="none", label=label)
    ax.axhline(0.0, color="0.7", lw=0.8)
    ax.set_xlabel("apex travel δ / mm")
    ax.set_ylabel("apex force F / N")
    _legend_beside(ax)
    return ax


def plot_energy(run: UnitCellRun, ax=None, *, spring: tuple[float, float, float] | None = None):
    """Strain energy (N·mm) against apex travel (mm), by branch, with its lower envelope."""
    ax = _axes(ax)
    _by_branch(run, run.energy, ax)
    _branch_keys(run, ax)
    grid = np.linspace(0.0, run.displacement.max(), 400)
    ax.plot(grid, run.energy_envelope(grid), color="0.3", lw=3, alpha=0.3, label="lower envelope")
    if spring is not None:
        ax.plot(grid, dome_energy(grid, *spring), "k:", lw=1.5, label="fitted spring law")
    ax.set_xlabel("apex travel δ / mm")
    ax.set_ylabel("strain energy / N·mm")
    _legend_beside(ax)
    return ax


def plot_meridians(run: UnitCellRun, ax=None, *, steps: Sequence[int] | None = None):
    """Deformed meridians ``(r, z)`` (mm) at a few steps (default: 8 spread along the path).

    Each in its branch's colour (as in :func:`plot_force`), dashed where unstable, with its own
    marker at the apex (``r = 0``) to tell apart two meridians of one branch.
    """
    ax = _axes(ax)
    if steps is None:
        steps = np.unique(np.linspace(0, run.n_steps - 1, 8).astype(int))
    markers = "os^Dv<>ph*"
    for n, i in enumerate(steps):
        r, z = run.shapes[i, :, 0], run.shapes[i, :, 1]
        style = "-" if run.stable[i] else "--"
        ax.plot(
            r,
            z,
            style,
            color=_branch_colour(run.branch[i]),
            lw=1.2,
            marker=markers[n % len(markers)],
            markevery=[int(np.argmin(r))],
            ms=5,
            label=f"δ = {run.displacement[i]:.2f} mm, branch {run.branch[i]}",
        )
    ax.set_aspect("equal")
    ax.set_xlabel("r / mm")
    ax.set_ylabel("z / mm")
    _legend_beside(ax)
    return ax
