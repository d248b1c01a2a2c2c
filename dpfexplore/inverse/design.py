"""Solve a scene: every target, verified, with the files of the report.

::

    >>> from dpfexplore.inverse import load_scene, design_scene
    >>> outcome = design_scene(load_scene("jobs/design-position-cheetah.toml"))  # doctest: +SKIP
    >>> outcome.rows[1]["tip"], outcome.rows[1]["objective"]                   # doctest: +SKIP

:data:`SOLVERS` maps each scene kind to the solver of one target
(:func:`dpfexplore.inverse.optimiser.solve_position_target`,
:func:`dpfexplore.inverse.gripper_design.solve_gripper`); :data:`REPORTS` to the function that
verifies and reports its result (:mod:`dpfexplore.inverse.design_report`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from .design_report import gripper_report, position_report, write_report
from .evaluation import Evaluator
from .gripper_design import solve_gripper
from .optimiser import TargetResult, solve_position_target
from .scene_jobs import SceneSpec

__all__ = ["REPORTS", "SOLVERS", "DesignOutcome", "Progress", "design_scene", "run_design"]

logger = logging.getLogger(__name__)

#: Scene kind -> ``solver(spec, target_index, evaluator) -> TargetResult``.
SOLVERS: dict[str, Callable[[SceneSpec, int, Evaluator], TargetResult]] = {
    "position": solve_position_target,
    "position_stiffness": lambda spec, i, ev: solve_position_target(spec, i, ev, exhaustive=True),
    "gripper": solve_gripper,
}
#: Scene kind -> ``report(spec, result, evaluator) -> dict`` (verified ``--json`` row).
REPORTS: dict[str, Callable[[SceneSpec, TargetResult, Evaluator], dict[str, Any]]] = {
    "position": position_report,
    "position_stiffness": position_report,
    "gripper": gripper_report,
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
    """Targets of a scene (the gripper has one: its set of apertures)."""
    return 1 if spec.kind == "gripper" else len(spec.targets)


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
            logger.info("target %d: objective %s, %s", i + 1, row["objective"],
                        "reachable" if row["reachable"] else "unreachable")  # fmt: skip
            if progress is not None:
                progress.advance(f"target {i + 1}/{total} {row['target']}: objective "
                                 f"{row['objective']:.3g}")  # fmt: skip
    finally:
        if progress is not None:
            progress.close()
    return DesignOutcome(spec=spec, rows=rows, evaluator=evaluator, wall_s=evaluator.wall_s)


def run_design(spec: SceneSpec, out: str | Path, *, plot: bool = False,
               progress: Progress | None = None) -> DesignOutcome:  # fmt: skip
    """Solve a scene and write its report to ``out`` (see :mod:`.design_report`)."""
    outcome = design_scene(spec, progress=progress)
    write_report(spec, outcome.rows, outcome.evaluator, Path(out), wall_s=outcome.wall_s,
                 plot=plot)  # fmt: skip
    return outcome
