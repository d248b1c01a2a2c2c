"""Solve a scene: every target, verified, with the files of the report.

::

    >>> from dpfexplore.inverse import load_scene, design_scene
    >>> outcome = design_scene(load_scene("jobs/design-position-cheetah.toml"))  # doctest: +SKIP
    >>> outcome.rows[1]["tip"], outcome.rows[1]["objective"]                   # doctest: +SKIP

:data:`SOLVERS` maps each scene kind to the solver of one target
(:func:`dpfexplore.inverse.engine.optimiser.solve_position_target`,
:func:`dpfexplore.inverse.scenes.gripper.solve.solve_gripper`,
:func:`dpfexplore.inverse.scenes.pickplace.solve.solve_pickplace`,
:func:`dpfexplore.inverse.scenes.walker.solve.solve_walker`); :data:`REPORTS` to the function that
verifies and reports its result (:mod:`dpfexplore.inverse.report`,
:mod:`dpfexplore.inverse.scenes.pickplace.report`, :mod:`dpfexplore.inverse.scenes.walker.report`),
and :data:`WRITERS` to the writer of its files where it is not the default.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ..sweep.result_dirs import check_output_dir, result_directory
from .engine.optimiser import TargetResult, solve_position_target
from .evaluation import Evaluator
from .report import gripper_report, position_report, write_report
from .scenes.gripper.solve import solve_gripper
from .scenes.pickplace.report import pickplace_report, write_timing_report
from .scenes.pickplace.solve import solve_pickplace
from .scenes.walker.report import walker_report, write_walker_report
from .scenes.walker.solve import solve_walker
from .spec import SceneSpec

__all__ = [
    "REPORTS",
    "SOLVERS",
    "WRITERS",
    "DesignOutcome",
    "Progress",
    "design_scene",
    "run_design",
]

logger = logging.getLogger(__name__)

#: Scene kind -> ``solver(spec, target_index, evaluator) -> TargetResult``.
SOLVERS: dict[str, Callable[[SceneSpec, int, Evaluator], TargetResult]] = {
    "position": solve_position_target,
    "position_stiffness": lambda spec, i, ev: solve_position_target(spec, i, ev, exhaustive=True),
    "gripper": solve_gripper,
    "pickplace": solve_pickplace,
    "walker_leg": solve_walker,
}
#: Scene kind -> ``report(spec, result, evaluator) -> dict`` (verified ``--json`` row).
REPORTS: dict[str, Callable[[SceneSpec, TargetResult, Evaluator], dict[str, Any]]] = {
    "position": position_report,
    "position_stiffness": position_report,
    "gripper": gripper_report,
    "pickplace": pickplace_report,
    "walker_leg": walker_report,
}
#: Scene kind -> writer of its report files (default :func:`.report.write_report`).
WRITERS: dict[str, Callable[..., list[Path]]] = {
    "pickplace": write_timing_report,
    "walker_leg": write_walker_report,
}


class Progress(Protocol):
    """Receives progress: ``start(total)``, ``advance(text)`` per target, ``close()``."""

    def start(self, total: int) -> None: ...  # noqa: D102

    def advance(self, text: str) -> None: ...  # noqa: D102

    def close(self) -> None: ...  # noqa: D102


@dataclass
class DesignOutcome:
    """A solved scene: one verified row per target, the evaluator (counts, history), wall time."""

    spec: SceneSpec
    rows: list[dict[str, Any]]
    evaluator: Evaluator
    wall_s: float


def n_targets(spec: SceneSpec) -> int:
    """Result rows of a scene (the gripper has one: its set of apertures)."""
    if spec.kind == "gripper":
        return 1
    if spec.kind == "pickplace":
        return spec.pickplace.n_results
    if spec.kind == "walker_leg":
        return spec.walker.n_results
    return len(spec.targets)


def _progress_text(i: int, total: int, row: dict[str, Any]) -> str:
    objective = row.get("objective")
    shown = f"{objective:.3g}" if isinstance(objective, (int, float)) else str(objective)
    return f"result {i + 1}/{total} {row.get('target')}: objective {shown}"


def design_scene(spec: SceneSpec, *, progress: Progress | None = None) -> DesignOutcome:
    """Solve every target of a scene and verify every reported design."""
    evaluator = Evaluator(max(spec.n_units))
    total = n_targets(spec)
    if progress is not None:
        progress.start(total)
    rows = []
    try:
        for i in range(total):
            result = SOLVERS[spec.kind](spec, i, evaluator)
            row = REPORTS[spec.kind](spec, result, evaluator)
            rows.append(row)
            logger.info(
                "target %d: objective %s, %s",
                i + 1,
                row.get("objective"),
                "reachable" if row["reachable"] else "unreachable",
            )
            if progress is not None:
                progress.advance(_progress_text(i, total, row))
    finally:
        if progress is not None:
            progress.close()
    return DesignOutcome(spec=spec, rows=rows, evaluator=evaluator, wall_s=evaluator.wall_s)


def run_design(
    spec: SceneSpec,
    out: str | Path,
    *,
    plot: bool = False,
    progress: Progress | None = None,
    force: bool = False,
) -> DesignOutcome:
    """Solve a scene and write its report to the result directory ``out``.

    ``out`` is checked before the solve (:func:`~dpfexplore.sweep.result_dirs.check_output_dir`:
    a directory holding another result needs ``force``) and written complete or not at all
    (:func:`~dpfexplore.sweep.result_dirs.result_directory`): files of an earlier run are never
    mixed with this one's.
    """
    check_output_dir(out, force=force)
    outcome = design_scene(spec, progress=progress)
    writer = WRITERS.get(spec.kind, write_report)
    facts = {"scene": spec.name, "kind": spec.kind, "results": len(outcome.rows)}
    with result_directory(out, kind="design", force=force, description=facts) as staging:
        writer(spec, outcome.rows, outcome.evaluator, staging, wall_s=outcome.wall_s, plot=plot)
    return outcome
