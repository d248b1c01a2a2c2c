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

__all__ = ["pickplace_figures", "target_label"]


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
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
    import matplotlib.pyplot as plt

    from ....plotting.design import plot_objective_history
    from ....plotting.timing import plot_difference_front, plot_reset_screen
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
    fig, ax = plt.subplots(figsize=(8, 6))
    plot_reset_screen(
        batch.H[:, slot],
        batch.t,
        screen.ev.value,
        screen.ev.admissible,
        designs=designs,
        ax=ax,
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
        fig, ax = plt.subplots(figsize=(6, 5))
        plot_objective_history(
            frame,
            ax=ax,
            labels={i: target_label(row) for i, row in enumerate(rows)},
            ylabel="best relative error of the reset time so far",
        )
        paths.append(_save(fig, out / "objective.png"))
    for i, row in enumerate(rows):
        if row.get("front"):
            fig, ax = plt.subplots(figsize=(6, 5))
            plot_difference_front(
                [(q["difference"], q["stiffness"], q["design"]["t"]) for q in row["front"]],
                lines=[(q["difference"], q["stiffness"]) for q in row.get("lines", []) if q["ok"]],
                weighted=None
                if "weighted" not in row
                else (row["weighted"]["difference"], row["weighted"]["stiffness"]),
                ax=ax,
            )
            paths.append(_save(fig, out / f"front-{i + 1:02d}.png"))
    return paths
