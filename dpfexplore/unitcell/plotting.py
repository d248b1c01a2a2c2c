"""Figures of one unit-cell run: force and energy against apex travel, deformed meridians.

``plot_*(run, ax=None) -> Axes``: no file I/O, no ``plt.show()`` (the project's plotting
convention); stable stretches solid, unstable ones dashed, one colour per branch.
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


def _by_branch(run: UnitCellRun, values, ax, label_first: str) -> None:
    for key in np.unique(run.branch):
        on = np.flatnonzero(run.branch == key)
        # include the next point so the pieces join
        piece = np.append(on, on[-1] + 1) if on[-1] + 1 < run.n_steps else on
        x, y, stable = run.displacement[piece], values[piece], run.stable[piece]
        color = f"C{key % 10}"
        for flag, style in ((True, "-"), (False, "--")):
            masked = np.where(stable == flag, y, np.nan)
            ax.plot(
                x,
                masked,
                style,
                color=color,
                lw=1.2,
                label=label_first if key == 0 and flag else None,
            )


def plot_force(run: UnitCellRun, ax=None, *, spring: tuple[float, float, float] | None = None):
    """Apex reaction (N) against apex travel (mm), by branch; ``spring = (k_b, α, d)`` drawn too.

    The spring law's force is drawn against the apex travel taken as its extension.
    """
    ax = _axes(ax)
    _by_branch(run, run.force, ax, "shell (dashed: unstable)")
    if spring is not None:
        x = np.linspace(0.0, run.displacement.max(), 300)
        ax.plot(x, dome_force(x, *spring), "k:", lw=1.5, label="fitted spring law")
    for state in run.zero_force_states:
        ax.plot(state.displacement, 0.0, "o" if state.stable else "x", color="k", ms=5)
    ax.axhline(0.0, color="0.7", lw=0.8)
    ax.set_xlabel("apex travel δ / mm")
    ax.set_ylabel("apex force F / N")
    ax.legend(fontsize=8)
    return ax


def plot_energy(run: UnitCellRun, ax=None, *, spring: tuple[float, float, float] | None = None):
    """Strain energy (N·mm) against apex travel (mm), by branch, with its lower envelope."""
    ax = _axes(ax)
    _by_branch(run, run.energy, ax, "shell (dashed: unstable)")
    grid = np.linspace(0.0, run.displacement.max(), 400)
    ax.plot(grid, run.energy_envelope(grid), color="0.3", lw=3, alpha=0.3, label="lower envelope")
    if spring is not None:
        ax.plot(grid, dome_energy(grid, *spring), "k:", lw=1.5, label="fitted spring law")
    ax.set_xlabel("apex travel δ / mm")
    ax.set_ylabel("strain energy / N·mm")
    ax.legend(fontsize=8)
    return ax


def plot_meridians(run: UnitCellRun, ax=None, *, steps: Sequence[int] | None = None):
    """Deformed meridians ``(r, z)`` (mm) at a few steps (default: 8 spread along the path)."""
    ax = _axes(ax)
    if steps is None:
        steps = np.unique(np.linspace(0, run.n_steps - 1, 8).astype(int))
    for i in steps:
        r, z = run.shapes[i, :, 0], run.shapes[i, :, 1]
        style = "-" if run.stable[i] else "--"
        ax.plot(
            r, z, style, lw=1.2, label=f"δ = {run.displacement[i]:.2f} (branch {run.branch[i]})"
        )
    ax.set_aspect("equal")
    ax.set_xlabel("r / mm")
    ax.set_ylabel("z / mm")
    ax.legend(fontsize=7)
    return ax
