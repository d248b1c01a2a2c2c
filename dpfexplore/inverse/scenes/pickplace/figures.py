"""Figures of the pick-and-place report (``dpfexplore design --plot``).

``reset-map.png``: the screening's reset times over the box with the reported designs;
``objective.png``: the best relative error of each result against evaluations; ``front-KK.png``:
the difference front (``RT_2 - RT_1`` against the grasp stiffness, ``t`` by colour).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .spec import PickPlaceSpec

__all__ = [
    "front_figure",
    "objective_figure",
    "pickplace_figures",
    "reset_map_figure",
    "target_label",
]


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path


def target_label(row: Mapping[str, Any]) -> str:
    """A result row's target as the legend names it: its reset time, units or the front."""
    if row.get("target_units"):
        units = ", ".join(str(u) for u in row["target_units"])
        resets = ", ".join(f"{r:g}" for r in row.get("target_reset") or [])
        return f"units {units}: reset {resets} s"
    if row.get("target_reset") is not None:
        return f"reset {row['target_reset']:g} s"
    return "max RT_2 - RT_1"


def reset_map_figure(
    H: np.ndarray,
    t: np.ndarray,
    value: np.ndarray,
    admissible: np.ndarray,
    designs: list[tuple[float, float, str]],
    *,
    method: str,
    h_label: str,
):
    """``reset-map.png``: the screening over the box (:func:`plot_reset_screen`'s arguments)."""
    from matplotlib.figure import Figure

    from ....plotting.timing import plot_reset_screen

    fig = Figure(figsize=(8, 6), layout="constrained")
    plot_reset_screen(
        H, t, value, admissible, designs=designs, ax=fig.subplots(), method=method, h_label=h_label
    )
    return fig


def objective_figure(history, rows: list[dict[str, Any]]):
    """``objective.png``: the best relative error of each result's target against evaluations.

    ``history`` holds the finite objectives only; ``rows`` are the ``--json`` rows (their
    targets name the lines).
    """
    from matplotlib.figure import Figure

    from ....plotting.design import plot_objective_history

    fig = Figure(figsize=(6, 5), layout="constrained")
    plot_objective_history(
        history,
        ax=fig.subplots(),
        labels={i: target_label(row) for i, row in enumerate(rows)},
        ylabel="best relative error of the reset time so far",
    )
    return fig


def front_figure(row: dict[str, Any]):
    """``front-KK.png``: the difference front of one ``--json`` row that has one."""
    from matplotlib.figure import Figure

    from ....plotting.timing import plot_difference_front

    fig = Figure(figsize=(6, 5), layout="constrained")
    plot_difference_front(
        [(q["difference"], q["stiffness"], q["design"]["t"]) for q in row["front"]],
        lines=[(q["difference"], q["stiffness"]) for q in row.get("lines", []) if q["ok"]],
        weighted=None
        if "weighted" not in row
        else (row["weighted"]["difference"], row["weighted"]["stiffness"]),
        ax=fig.subplots(),
    )
    return fig


def pickplace_figures(
    spec: SceneSpec[PickPlaceSpec],
    rows: list[dict[str, Any]],
    evaluator: SceneEvaluator,
    history,
    out: Path,
) -> list[Path]:
    """Write the report's figures of the ``--json`` rows ``rows`` in ``out``; their paths."""
    import matplotlib

    matplotlib.use("Agg")
    from .screen import screen_pickplace

    screen = screen_pickplace(spec, evaluator)
    z = screen.ev.z
    batch = screen.problem.designs(z)
    slot = next(k for k in range(batch.H.shape[1]) if np.ptp(batch.H[:, k]) > 0)
    designs = [
        (
            r["design"]["H"][slot],
            r["design"]["t"],
            f"{r['target_reset']}" if r["target_reset"] is not None else "max diff",
        )
        for r in rows
        if r.get("design") is not None
    ]
    fig = reset_map_figure(
        batch.H[:, slot],
        batch.t,
        screen.ev.value,
        screen.ev.admissible,
        designs,
        method=screen.method,
        h_label=f"H_{slot + 1} (mm)",
    )
    paths = [_save(fig, out / "reset-map.png")]
    frame = (
        history[np.isfinite(history["objective"].to_numpy(dtype=float))]
        if "objective" in history
        else history
    )
    if len(frame):
        paths.append(_save(objective_figure(frame, rows), out / "objective.png"))
    for i, row in enumerate(rows):
        if row.get("front"):
            paths.append(_save(front_figure(row), out / f"front-{i + 1:02d}.png"))
    return paths
