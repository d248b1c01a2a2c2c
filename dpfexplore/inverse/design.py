"""Solve a scene: every target, verified, with the files of the report.

::

    >>> from dpfexplore.inverse import load_scene, design_scene
    >>> outcome = design_scene(load_scene("jobs/design-position-cheetah.toml"))  # doctest: +SKIP
    >>> outcome.results[1].reachable, outcome.rows[1]["objective"]            # doctest: +SKIP

Each kind's solver, report and writer come from its record in
:data:`dpfexplore.inverse.kinds.SCENE_KINDS`; nothing here knows a kind.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ..io.result_dirs import check_output_dir, result_directory
from .evaluation import SceneEvaluator
from .kinds import SCENE_KINDS
from .scene_kind import SceneResult
from .spec import SceneSpec

__all__ = [
    "DesignOutcome",
    "TargetProgress",
    "design_scene",
    "run_design",
]

logger = logging.getLogger(__name__)


class TargetProgress(Protocol):
    """Receives progress: ``start(total)``, ``advance(text)`` per target, ``close()``.

    Optional: ``batch(text)``, told after each evaluation batch of the optimiser where the
    target under way is (``"target 2/5: refining 12/60"``: iterations done of the budget);
    ``stage(text)``, told what :func:`run_design` does after the targets (writing the report).
    """

    def start(self, total: int) -> None: ...  # noqa: D102

    def advance(self, text: str) -> None: ...  # noqa: D102

    def close(self) -> None: ...  # noqa: D102


@dataclass
class DesignOutcome:
    """A solved scene: one verified result per row, the evaluator (counts, history), wall time.

    Attributes
    ----------
    spec : SceneSpec
    results : list of SceneResult
        The kind's result records (:class:`~.scene_kind.SceneResult`).
    evaluator : SceneEvaluator
    wall_s : float
        Seconds of the whole solve.
    """

    spec: SceneSpec
    results: list[SceneResult]
    evaluator: SceneEvaluator
    wall_s: float

    @property
    def rows(self) -> list[dict[str, Any]]:
        """The results as ``--json`` rows (what ``summary.json`` holds)."""
        return [r.to_dict() for r in self.results]


def _progress_text(i: int, total: int, row: Mapping[str, Any]) -> str:
    objective = row.get("objective")
    shown = f"{objective:.3g}" if isinstance(objective, (int, float)) else str(objective)
    return f"result {i + 1}/{total} {row.get('target')}: objective {shown}"


def _batch_reporter(batch, i: int, total: int):
    def report(what: str, done: int, of: int) -> None:
        batch(f"target {i + 1}/{total}: {what} {done}/{of}")

    return report


def design_scene(spec: SceneSpec, *, progress: TargetProgress | None = None) -> DesignOutcome:
    """Solve every target of a scene and verify every reported design."""
    evaluator = SceneEvaluator(max(spec.n_units))
    kind = SCENE_KINDS[spec.kind]
    total = spec.kind_spec.n_results
    if progress is not None:
        progress.start(total)
    results = []
    batch = getattr(progress, "batch", None)
    try:
        for i in range(total):
            if batch is not None:
                evaluator.on_batch = _batch_reporter(batch, i, total)
            outcome = kind.solve(spec, i, evaluator)
            result = kind.report(spec, outcome, evaluator)
            results.append(result)
            row = result.to_dict()
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
    return DesignOutcome(spec=spec, results=results, evaluator=evaluator, wall_s=evaluator.wall_s)


def run_design(
    spec: SceneSpec,
    out: str | Path,
    *,
    plot: bool = False,
    progress: TargetProgress | None = None,
    force: bool = False,
) -> DesignOutcome:
    """Solve a scene and write its report to the result directory ``out``.

    ``out`` is checked before the solve
    (:func:`~dpfexplore.io.result_dirs.check_output_dir`: a directory holding another
    result needs ``force``) and written complete or not at all
    (:func:`~dpfexplore.io.result_dirs.result_directory`): files of an earlier run are
    never mixed with this one's.
    """
    check_output_dir(out, force=force)
    outcome = design_scene(spec, progress=progress)
    writer = SCENE_KINDS[spec.kind].write
    facts = {
        "scene": spec.name,
        "kind": spec.kind,
        "results": len(outcome.results),
        "constants": spec.constants.fingerprint,
    }
    stage = getattr(progress, "stage", None)
    if stage is not None:
        stage("writing the report and figures" if plot else "writing the report")
    with result_directory(out, kind="design", force=force, description=facts) as staging:
        writer(spec, outcome.results, outcome.evaluator, staging, wall_s=outcome.wall_s, plot=plot)
    return outcome
