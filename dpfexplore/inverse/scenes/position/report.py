"""The position scenes' verified results and the files they write.

Every reported design (the best design of each target, each point of a front, the weighted-sum
design, the reference) is re-solved alone by :func:`~dpfexplore.inverse.report.verify_state`;
the tip, objective and stiffness reported are that re-solve's.

Files (:func:`write_position_report`)
    ``summary.json``, ``history.parquet``   as :func:`dpfexplore.inverse.report.write_summary`
    ``target-KK.toml``        the best design of target KK as a ``[design]`` table
                              (``dpfexplore states`` reads it back) with a ``[result]`` table
    ``*.png``                 with ``plot=True``: the finger in each targeted state with its
                              target, the objective against evaluations, the front, and the
                              reachable region of unreachable targets
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ....lookup.files import write_constants_beside
from ....model.design import Design
from ....model.formatting import json_number
from ...engine.optimiser import FrontPoint, ResidualRefinement, TargetResult
from ...evaluation import SceneEvaluator
from ...report import VERIFIED_BY, StateCheck, verify_state, write_result_row, write_summary
from ...spec import SceneSpec
from .spec import PositionSpec

__all__ = [
    "Domination",
    "FrontEntry",
    "PositionResult",
    "VerifiedDesign",
    "position_report",
    "verified_design",
    "write_position_report",
]


@dataclass(frozen=True)
class VerifiedDesign:
    """A design re-solved alone in one state, measured against a target tip.

    Attributes
    ----------
    design : Design
    state : str
        The state re-solved (bits).
    check : StateCheck
        The re-solve (tip in mm, stiffness in N/mm).
    objective : float
        ``|tip - target|²``, mm²; ``inf`` where the state is not stable.
    """

    design: Design
    state: str
    check: StateCheck
    objective: float

    def to_dict(self) -> dict[str, Any]:
        """The design's part of a ``--json`` row."""
        return {
            "design": self.design.to_dict(),
            "n_units": self.design.n_units,
            "state": self.state,
            "tip": list(self.check.tip),
            "objective": json_number(self.objective),
            "distance_mm": json_number(math.sqrt(self.objective)),
            "stiffness": json_number(self.check.stiffness),
            "fitted_range": bool(self.design.in_fitted_range),
            "fitted_range_note": self.design.fitted_range_note,
            "verification": {
                "method": VERIFIED_BY,
                "status": self.check.status,
                "stable": self.check.stable,
                "min_eig": json_number(self.check.min_eig),
            },
        }


@dataclass(frozen=True)
class FrontEntry:
    """One rung of a stiffness front: the stiffest design within ``tolerance_mm`` (mm), if any."""

    tolerance_mm: float
    design: VerifiedDesign | None

    def to_dict(self) -> dict[str, Any]:
        """The rung's ``--json`` entry."""
        if self.design is None:
            return {"tolerance_mm": self.tolerance_mm, "design": None}
        return {"tolerance_mm": self.tolerance_mm, **self.design.to_dict()}


@dataclass(frozen=True)
class Domination:
    """The tightest design of a row that is closer to the target and stiffer than the reference.

    Attributes
    ----------
    tolerance_mm : float or None
        Its front rung, mm (None: the row's best design).
    distance_mm : float
        Its distance to the target, mm.
    stiffness : float
        Its tip stiffness, N/mm.
    stiffness_ratio : float
        Its stiffness over the reference's.
    """

    tolerance_mm: float | None
    distance_mm: Any
    stiffness: Any
    stiffness_ratio: float

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` entry."""
        return {
            "tolerance_mm": self.tolerance_mm,
            "distance_mm": self.distance_mm,
            "stiffness": self.stiffness,
            "stiffness_ratio": self.stiffness_ratio,
        }


@dataclass(frozen=True)
class PositionResult:
    """One target of a position scene, verified (the ``--json`` row of :meth:`to_dict`).

    Attributes
    ----------
    target : (x, y)
        The target tip, mm.
    reachable : bool
        The best design's re-solve is stable and within the scene's tolerance.
    best : VerifiedDesign
        The best design found (the nearest one when the target is out of reach).
    evaluations : dict of str to int
        Evaluations of this target by kind.
    wall_s : float
        Seconds spent on this target.
    best_objective_per_n : dict of int to float
        Best objective per number of units, mm².
    proof : str or None
        Why an unreachable target is unreachable.
    front : tuple of FrontEntry
        The stiffness front (position_stiffness).
    weights : (w1, w2) or None
    weighted : VerifiedDesign or None
        The weighted-sum design.
    reference : VerifiedDesign or None
        The target's reference design, re-solved in its all-inverted state.
    dominates_reference : Domination or None
    """

    target: tuple[float, float]
    reachable: bool
    best: VerifiedDesign
    evaluations: dict[str, int]
    wall_s: float
    best_objective_per_n: dict[int, float]
    proof: str | None = None
    front: tuple[FrontEntry, ...] = ()
    weights: tuple[float, float] | None = None
    weighted: VerifiedDesign | None = None
    reference: VerifiedDesign | None = None
    dominates_reference: Domination | None = field(default=None)

    @property
    def met(self) -> bool:
        """The target was met (the position scenes have no further check)."""
        return self.reachable

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row."""
        row: dict[str, Any] = {
            "target": list(self.target),
            "reachable": self.reachable,
            **self.best.to_dict(),
            "evaluations": dict(self.evaluations),
            "wall_s": self.wall_s,
            "best_objective_per_n": {
                str(n): json_number(v) for n, v in self.best_objective_per_n.items()
            },
        }
        if not self.reachable:
            row["nearest_tip"] = list(self.best.check.tip)
            row["proof"] = self.proof
        if self.front:
            row["front"] = [point.to_dict() for point in self.front]
        if self.weighted is not None:
            row["weighted"] = {"weights": list(self.weights), **self.weighted.to_dict()}
        if self.reference is not None:
            row["reference"] = self.reference.to_dict()
            row["dominates_reference"] = (
                None if self.dominates_reference is None else self.dominates_reference.to_dict()
            )
        return row


def verified_design(
    design: Design, state: str, target, evaluator: SceneEvaluator
) -> VerifiedDesign:
    """``design`` re-solved alone in ``state`` and measured against the ``target`` tip (mm)."""
    check = verify_state(design, state, evaluator)
    tip = np.array(check.tip)
    objective = float(np.sum((tip - np.asarray(target)) ** 2)) if check.stable else math.inf
    return VerifiedDesign(design=design, state=state, check=check, objective=objective)


def _verified_run(run: ResidualRefinement | FrontPoint, target, evaluator) -> VerifiedDesign:
    design = run.problem.designs(np.atleast_2d(run.z)).design(0)
    return verified_design(design, run.problem.state_bits, target, evaluator)


def position_report(
    spec: SceneSpec[PositionSpec], result: TargetResult, evaluator: SceneEvaluator
) -> PositionResult:
    """The verified result of one position target (its front and weighted sum when solved)."""
    p = spec.kind_spec
    target = p.targets[result.target_index]
    best = _verified_run(result.best, target.point, evaluator)
    objective = json_number(best.objective)
    reachable = best.check.stable and objective is not None and objective <= p.tolerance
    proof = None
    if not reachable:
        proof = (
            f"{spec.optimiser.starts_per_n} gradient refinements per N from the best distinct of "
            f"{spec.optimiser.candidates_per_n} Latin-hypercube candidates per N all stopped above "
            f"the tolerance {p.tolerance:g} mm²; best objective per N in "
            "best_objective_per_n, every evaluated tip in history.parquet"
        )
    front = tuple(
        FrontEntry(
            point.tolerance,
            None if point.z is None else _verified_run(point, target.point, evaluator),
        )
        for point in result.front
    )
    weighted = None
    if result.weighted is not None:
        weighted = _verified_run(result.weighted, target.point, evaluator)
    out = PositionResult(
        target=target.point,
        reachable=bool(reachable),
        best=best,
        evaluations=dict(result.counts),
        wall_s=result.wall_s,
        best_objective_per_n=dict(result.per_n),
        proof=proof,
        front=front,
        weights=getattr(p, "weights", None),
        weighted=weighted,
    )
    if target.reference is None:
        return out
    reference = verified_design(
        target.reference, "1" * target.reference.n_units, target.point, evaluator
    )
    out = replace(out, reference=reference)
    return replace(out, dominates_reference=_dominating(out.to_dict(), reference.to_dict()))


def _dominating(row: Mapping[str, Any], ref: Mapping[str, Any]) -> Domination | None:
    """The tightest front point (or the best design) closer to the target and stiffer than ref."""
    if ref["objective"] is None or ref["stiffness"] is None:
        return None
    candidates = [p for p in row.get("front", []) if p.get("design") is not None]
    candidates.append(
        {
            "tolerance_mm": None,
            **{k: row[k] for k in ("objective", "stiffness", "distance_mm", "n_units")},
        }
    )
    for p in candidates:
        if p["objective"] is None or p["stiffness"] is None:
            continue
        if p["objective"] < ref["objective"] and p["stiffness"] > ref["stiffness"]:
            return Domination(
                tolerance_mm=p["tolerance_mm"],
                distance_mm=p["distance_mm"],
                stiffness=p["stiffness"],
                stiffness_ratio=p["stiffness"] / ref["stiffness"],
            )
    return None


# ----------------------------------------------------------------------------- files


def write_position_report(
    spec: SceneSpec[PositionSpec],
    results: list[PositionResult],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Write summary, history, design TOMLs and (optionally) figures; returns the paths.

    Writes into ``out`` as it stands (a file of an earlier run there would stay):
    :func:`dpfexplore.inverse.design.run_design` passes the staging directory of
    :func:`dpfexplore.io.result_dirs.result_directory`, so ``dpfexplore design --out
    DIR`` is complete or absent and holds only this run's files.
    """
    out = Path(out)
    history = evaluator.history()
    rows = [r.to_dict() for r in results]
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s, history=history)
    for i, row in enumerate(rows):
        path = out / f"target-{i + 1:02d}.toml"
        title = f"{spec.name}: target {i + 1} {row['target']} mm"
        write_result_row(path, row, title=title, constants=spec.constants)
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _figures(results, rows, history, out)
    return written


def _figures(results: list[PositionResult], rows, history, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ....plotting.design import (
        plot_front,
        plot_objective_history,
        plot_reachable_region,
        plot_target_shapes,
    )

    paths = []

    def save(ax_or_fig, name: str) -> None:
        fig = getattr(ax_or_fig, "figure", ax_or_fig)
        path = out / name
        fig.savefig(path, dpi=130, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)

    save(plot_objective_history(history), "objective.png")
    save(
        plot_target_shapes(
            [r.best.check.nodes for r in results],
            [r["target"] for r in rows],
            [r["reachable"] for r in rows],
        ),
        "targets.png",
    )
    for i, row in enumerate(rows):
        if row.get("front"):
            fronts = [
                (p["tolerance_mm"], p.get("distance_mm"), p.get("stiffness"))
                for p in row["front"]
                if p.get("design") is not None
            ]
            ref = row.get("reference")
            save(
                plot_front(
                    fronts,
                    reference=None if ref is None else (ref["distance_mm"], ref["stiffness"]),
                    title=f"target {i + 1} {row['target']}",
                ),
                f"front-{i + 1:02d}.png",
            )
        if not row["reachable"]:
            part = history[history["target"] == i]
            save(
                plot_reachable_region(part, row["target"], row["tip"]), f"reachable-{i + 1:02d}.png"
            )
    return paths
