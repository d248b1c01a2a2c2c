"""The pick-and-place scene's verified results and the files they write.

Every design reported here was re-simulated alone in the full model (Rodas4) over its whole
horizon (no early stop) at the scene's ``verify_atol``; the reset times, classes and final states
reported are that run's. Grasp stiffnesses are :func:`dpfexplore.solvers.statics.find_state`
re-solves. Units whose reach ``d`` is clamped are classed ``no_contact``. Every design carries
``fitted_range`` and ``fitted_range_note`` (:attr:`dpfexplore.model.design.Design.in_fitted_range`).

Files (:func:`write_pickplace_report`)
    ``summary.json``, ``history.parquet``   as :func:`dpfexplore.inverse.report.write_summary`
    ``result-KK.toml``     the design of result KK (``[design]``, read by ``dpfexplore states``
                           and ``dpfexplore simulate``) and ``[result]``
    ``*.png``              with ``plot=True``: :mod:`.figures`
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

from ....lookup.files import write_constants_beside, write_design_file
from ....model.design import Design
from ....model.formatting import json_number
from ....solvers.statics import find_state
from ...evaluation import SceneEvaluator
from ...report import TIMING_VERIFIED_BY as VERIFIED_BY
from ...report import json_times, write_summary
from ...spec import SceneSpec
from .figures import pickplace_figures
from .front import DifferencePoint
from .screen import DesignCheck
from .solve import Attempt, PickPlaceOutcome
from .spec import PickPlaceSpec, PulseSpec

__all__ = [
    "DifferenceEntry",
    "DifferenceResult",
    "GraspCheck",
    "PickPlaceContext",
    "ResetTargetResult",
    "pickplace_report",
    "write_pickplace_report",
]


#: The fields of a result row without a design: nothing was found to verify.
UNREACHED = {
    "reachable": False,
    "design": None,
    "reset_times": None,
    "stiffness": None,
    "objective": None,
    "fitted_range": None,
    "fitted_range_note": None,
}


def design_flags(design: Design) -> dict[str, Any]:
    """``design``, ``n_units``, ``fitted_range`` and its note."""
    return {
        "design": design.to_dict(),
        "n_units": design.n_units,
        "fitted_range": bool(design.in_fitted_range),
        "fitted_range_note": design.fitted_range_note,
    }


@dataclass(frozen=True)
class GraspCheck:
    """The grasp state of a design re-solved alone by ``find_state``.

    Attributes
    ----------
    stiffness : float or None
        Tip stiffness, N/mm (None where the state is not stable).
    status : str
    stable : bool
    """

    stiffness: float | str | None
    status: str
    stable: bool


def _grasp(design: Design, state: str, evaluator: SceneEvaluator) -> GraspCheck:
    result = find_state(design, state)
    evaluator.count("verifications")
    return GraspCheck(
        stiffness=json_number(result.stiffness) if result.stable else None,
        status=result.status.label,
        stable=bool(result.stable),
    )


def _check_entry(check: DesignCheck) -> dict[str, Any]:
    return {
        "reset_times": json_times(check["reset_times"]),
        "classes": check["classes"],
        "final_state": check["final_state"],
        "objective_unit": check["objective_unit"],
        "reset_time": json_number(check["value"]),
    }


class ScreeningFacts(TypedDict):
    """The screening grid of a scene run: its reduced model, a note, designs, seconds."""

    method: str
    note: str
    designs: int
    wall_s: float


class SearchFacts(TypedDict, total=False):
    """A target's search: brackets found, brackets tried and the runs of the one that won."""

    brackets: int
    tried: int
    root_evaluations: int | dict | None


@dataclass(frozen=True)
class PickPlaceContext:
    """What every result row of a pick-and-place scene run states about its search.

    Attributes
    ----------
    objective_kind : str
        ``"target"``, ``"unit_target"`` or ``"difference"``.
    reset_unit : str or int
        The scene's objective unit (``"last"`` or 1-based).
    grasp_state : str
    profile : PulseSpec
        The scene's pulse (MPa, s).
    reachable_range : dict
        Reset times reachable on the screening grid (s; :func:`.screen.reachable_range`).
    screening : ScreeningFacts
    evaluations : dict of str to int
        Evaluations of this result by kind.
    wall_s : float
        Seconds spent on this result.
    """

    objective_kind: str
    reset_unit: str | int
    grasp_state: str
    profile: PulseSpec
    reachable_range: dict[str, Any]
    screening: ScreeningFacts
    evaluations: dict[str, int]
    wall_s: float

    def to_dict(self) -> dict[str, Any]:
        """The row's closing fields."""
        return {
            "objective_kind": self.objective_kind,
            "reset_unit": self.reset_unit,
            "grasp_state": self.grasp_state,
            "profile": self.profile.to_dict(),
            "reachable_range": self.reachable_range,
            "screening": self.screening,
            "evaluations": dict(self.evaluations),
            "wall_s": self.wall_s,
        }


@dataclass(frozen=True)
class ResetTargetResult:
    """A target reset time (or two units' times) of a pick-and-place scene, verified.

    Attributes
    ----------
    target : float or list of float
        The target reset time, s (the two units' times for a unit target).
    units : list of int or None
        The unit target's units (1-based).
    context : PickPlaceContext
    best : Attempt or None
        The design found, with its full-model check (None: nothing was found to verify).
    grasp : GraspCheck or None
        Its grasp state's re-solve.
    reachable : bool
        Its verified reset time is within the tolerance and its hold units stay inverted.
    search : SearchFacts
    alternatives : list of Attempt
        The unit target's other answers.
    proof : str or None
        Why nothing (or nothing within the tolerance) was found.
    """

    target: float | list[float]
    units: list[int] | None
    context: PickPlaceContext
    best: Attempt | None
    grasp: GraspCheck | None
    reachable: bool
    search: SearchFacts
    alternatives: tuple[Attempt, ...] = ()
    proof: str | None = None

    @property
    def met(self) -> bool:
        """The target was met."""
        return self.reachable

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row."""
        row: dict[str, Any] = {"target": self.target, "target_reset": self.target}
        if self.units is not None:
            row["target_units"] = self.units
        if self.best is None:
            row.update(UNREACHED, proof=self.proof)
            return {**row, **self.context.to_dict()}
        best, check = self.best, self.best["check"]
        row.update(
            {
                "reachable": self.reachable,
                **design_flags(best["design"]),
                **_check_entry(check),
                "relative_error": json_number(best["error"]),
                "objective": json_number(best["error"]),
                "stiffness": self.grasp.stiffness,
                "verification": {
                    "method": VERIFIED_BY.format(atol=check["atol"]),
                    "atol": check["atol"],
                    "status": check["status"],
                    "t_end": check["t_end"],
                    "grasp_state": self.grasp.status,
                },
                "search": self.search,
                "wall_s_note": "the target's search and verification; the screening and the "
                "reachable range of the scene are in screening.wall_s and reachable_range.wall_s "
                "(shared by every result of the run; the first result's wall_s includes "
                "its first stage)",
            }
        )
        if self.units is not None:
            row["unit_errors"] = [json_number(e) for e in best["unit_errors"]]
            row["alternatives"] = [
                {
                    "H": list(a["design"].H),
                    "t": a["design"].t,
                    "fitted_range": bool(a["design"].in_fitted_range),
                    "reset_times": json_times(a["check"]["reset_times"]),
                    "unit_errors": [json_number(e) for e in a["unit_errors"]],
                }
                for a in self.alternatives
            ]
        if not self.reachable:
            row["nearest"] = {
                "reset_time": json_number(check["value"]),
                "relative_error": json_number(best["error"]),
            }
            row["proof"] = self.proof
        return {**row, **self.context.to_dict()}


@dataclass(frozen=True)
class DifferenceEntry:
    """A design of the difference front, verified under both profiles.

    Attributes
    ----------
    point : DifferencePoint
        The design, its two full-model runs and ``RT_2 - RT_1`` (s).
    grasp : GraspCheck
        Its grasp state's re-solve (stiffness in N/mm).
    """

    point: DifferencePoint
    grasp: GraspCheck

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` entry."""
        q = self.point
        c1, c2 = q["checks"]
        return {
            **design_flags(q["design"]),
            "difference": json_number(q["difference"]),
            "stiffness": self.grasp.stiffness,
            "reset_times": json_times(c1["reset_times"]),
            "reset_times_profile_2": json_times(c2["reset_times"]),
            "classes": c1["classes"],
            "classes_profile_2": c2["classes"],
            "reset_time": json_number(c1["value"]),
            "reset_time_profile_2": json_number(c2["value"]),
            "ok": bool(q["ok"]),
        }


@dataclass(frozen=True)
class DifferenceResult:
    """The two-profile difference objective of a pick-and-place scene, verified.

    Attributes
    ----------
    context : PickPlaceContext
    profiles : (PulseSpec, PulseSpec)
        The scene's pulse and the second profile (MPa, s).
    max_reset : float
        Cap on every reset under both profiles, s.
    best : DifferenceEntry or None
        The largest difference of the front (None: no line gave an admissible design).
    front : tuple of DifferenceEntry
        Non-dominated in difference and grasp stiffness.
    lines : tuple of DifferencePoint
        Every line's optimum (not re-verified).
    weights : (w1, w2) or None
    weighted : DifferenceEntry or None
        The paper's weighted sum's choice on the front.
    verify_atol : float
        mm.
    """

    context: PickPlaceContext
    profiles: tuple[PulseSpec, PulseSpec]
    max_reset: float
    best: DifferenceEntry | None
    front: tuple[DifferenceEntry, ...]
    lines: tuple[DifferencePoint, ...]
    weights: tuple[float, float] | None
    weighted: DifferenceEntry | None
    verify_atol: float

    @property
    def reachable(self) -> bool:
        """A verified front exists."""
        return self.best is not None

    @property
    def met(self) -> bool:
        """A verified front exists."""
        return self.reachable

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row."""
        row: dict[str, Any] = {
            "target": None,
            "target_reset": None,
            "profiles": [self.profiles[0].to_dict(), self.profiles[1].to_dict()],
            "max_reset": self.max_reset,
        }
        if self.best is None:
            row.update(UNREACHED, front=[])
            return {**row, **self.context.to_dict()}
        main = self.best.to_dict()
        row.update(
            {
                "reachable": True,
                **main,
                "objective": main["difference"],
                "verification": {
                    "method": VERIFIED_BY.format(atol=self.verify_atol),
                    "atol": self.verify_atol,
                },
                "front": [q.to_dict() for q in self.front],
                "lines": [
                    {
                        "t": q["design"].t,
                        "H": list(q["design"].H),
                        "difference": json_number(q["difference"]),
                        "stiffness": json_number(q["stiffness"]),
                        "ok": bool(q["ok"]),
                    }
                    for q in self.lines
                ],
            }
        )
        if self.weighted is not None:
            row["weighted"] = {"weights": list(self.weights), **self.weighted.to_dict()}
        return {**row, **self.context.to_dict()}


def pickplace_report(
    spec: SceneSpec[PickPlaceSpec], result: PickPlaceOutcome, evaluator: SceneEvaluator
) -> ResetTargetResult | DifferenceResult:
    """The verified result of one pick-and-place result row (target, unit pair or front)."""
    from .screen import reachable_range, screen_pickplace

    p = spec.kind_spec
    ranges = reachable_range(spec, evaluator)
    screen = screen_pickplace(spec, evaluator)
    context = PickPlaceContext(
        objective_kind=result.kind,
        reset_unit=p.reset_unit,
        grasp_state=p.grasp_state,
        profile=p.pulse,
        reachable_range=ranges,
        screening=ScreeningFacts(
            method=screen.method,
            note=screen.note,
            designs=len(screen.ev.z),
            wall_s=screen.wall_s,
        ),
        evaluations=dict(result.counts),
        wall_s=result.wall_s,
    )
    if result.kind == "difference":
        return _difference_result(spec, result, context, evaluator)
    best = result.best
    units = result.units if result.kind == "unit_target" else None
    search = SearchFacts(brackets=result.brackets, tried=len(result.attempts))
    if best is None:
        return ResetTargetResult(
            target=result.target,
            units=units,
            context=context,
            best=None,
            grasp=None,
            reachable=False,
            search=search,
            proof="no admissible design of the screening grid brackets the target and none is "
            "near it",
        )
    grasp = _grasp(best["design"], p.grasp_state, evaluator)
    reachable = bool(best["error"] <= p.tolerance and best["check"]["admissible"])
    proof = None
    if not reachable:
        proof = (
            f"{result.brackets} bracket(s) of the target on the screening grid "
            f"({p.grid_t} x {p.grid_H}); {len(result.attempts)} closed on the full model, none "
            f"within {p.tolerance:g}; see reachable_range"
        )
    return ResetTargetResult(
        target=result.target,
        units=units,
        context=context,
        best=best,
        grasp=grasp,
        reachable=reachable,
        search=SearchFacts(**search, root_evaluations=best.get("root_evaluations")),
        alternatives=tuple(a for a in result.attempts if a is not best),
        proof=proof,
    )


def _difference_result(
    spec: SceneSpec[PickPlaceSpec],
    result: PickPlaceOutcome,
    context: PickPlaceContext,
    evaluator: SceneEvaluator,
) -> DifferenceResult:
    p = spec.kind_spec
    d = p.difference

    def entry(q: DifferencePoint) -> DifferenceEntry:
        return DifferenceEntry(point=q, grasp=_grasp(q["design"], p.grasp_state, evaluator))

    best = None if result.best is None else entry(result.best)
    front = () if result.best is None else tuple(entry(q) for q in result.front)
    weighted = None
    if result.best is not None and result.weighted is not None:
        weighted = entry(result.weighted)
    return DifferenceResult(
        context=context,
        profiles=(p.pulse, d.pulse),
        max_reset=d.max_reset,
        best=best,
        front=front,
        lines=tuple(result.lines),
        weights=d.weights,
        weighted=weighted,
        verify_atol=p.verify_atol,
    )


# ----------------------------------------------------------------------------- files


def _write_result(path: Path, row: Mapping[str, Any], title: str, constants=None) -> Path:
    keys = (
        "objective_kind",
        "target_reset",
        "target_units",
        "reset_unit",
        "reset_times",
        "reset_times_profile_2",
        "classes",
        "final_state",
        "reset_time",
        "relative_error",
        "difference",
        "stiffness",
        "grasp_state",
        "reachable",
        "fitted_range",
        "fitted_range_note",
    )
    comments = [
        title,
        "Written by dpfexplore design; [design] is read by dpfexplore states and "
        "dpfexplore simulate.",
    ]
    result = {key: row.get(key) for key in keys}
    return write_design_file(path, row["design"], comments, result, constants=constants)


def write_pickplace_report(
    spec: SceneSpec[PickPlaceSpec],
    results: list[ResetTargetResult | DifferenceResult],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Summary, history, result TOMLs and (optionally) figures; the paths.

    Writes into ``out`` as it stands: :func:`dpfexplore.inverse.design.run_design` passes the
    staging directory of :func:`dpfexplore.io.result_dirs.result_directory`, so the
    report appears complete or not at all.
    """
    out = Path(out)
    rows = [r.to_dict() for r in results]
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s)
    for i, row in enumerate(rows):
        if row.get("design") is None:
            continue
        path = out / f"result-{i + 1:02d}.toml"
        what = (
            f"target reset {row['target_reset']} s"
            if row["target_reset"] is not None
            else "largest reset-time difference of the two profiles"
        )
        title = f"{spec.name}: result {i + 1}, {what}"
        _write_result(path, row, title, constants=spec.constants)
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += pickplace_figures(spec, rows, evaluator, evaluator.history(), out)
    return written
