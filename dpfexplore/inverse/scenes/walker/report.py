"""The walker-leg scene's verified rows and files (leg TOMLs, tip paths, gait timing diagrams).

A row (``--json``) per designed leg: each section's design, each unit's class, reset time and
inversion pressure (from the verification runs of the search, at ``verify_atol``), every
requirement with its value, bound and whether it is met, the stride at the walking gait against
the monostable leg's at the same gait, the tip path, the fitted-range flag.

Files (:func:`write_walker_report`)
    ``summary.json``, ``history.parquet``   as :func:`dpfexplore.inverse.report.write_summary`
    ``leg-<kind>.toml``    the designed leg as a leg file (``dpfexplore simulate-leg``)
    ``*.png``              with ``plot=True``: tip paths against the monostable leg and the gait
                           timing diagrams
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from ....io.toml_write import write_toml
from ....lookup.files import CONSTANTS_FILE, write_constants_beside
from ....model.constants_set import DEFAULT
from ....model.design import Design
from ....model.formatting import json_number
from ....solvers.legs.leg import LegResult
from ...evaluation import SceneEvaluator
from ...report import TIMING_VERIFIED_BY as VERIFIED_BY
from ...report import json_times, write_summary
from ...spec import SceneSpec
from .legs import Requirement
from .solve import LegOutcome, violation
from .spec import GaitSpec, WalkerSpec

__all__ = [
    "UnitRow",
    "WalkerLegResult",
    "inverted_intervals",
    "timing_figure",
    "tip_path_figure",
    "walker_report",
    "write_walker_report",
]

_ROLES = ("purple", "green", "action")


def _value(v: Any) -> Any:
    if isinstance(v, (bool, str)) or v is None:
        return v
    if isinstance(v, (int, float, np.floating, np.integer)):
        return json_number(float(v))
    return v


def _path_rows(leg, digits: int = 6) -> list[list[float | None]]:
    rows = np.round(np.column_stack([leg.t, leg.tip_path]), digits).tolist()
    return [[None if not np.isfinite(v) else v for v in row] for row in rows]


#: One unit of a designed leg, verified under its section's phase: ``H``, ``t`` (mm), ``class``
#: (None: never inverted), ``reset_time`` (s; ``"inf"`` never, None never inverted),
#: ``inversion_pressure_MPa``, and the ``phase`` and ``pressure_MPa`` of its section's run.
UnitRow = TypedDict(
    "UnitRow",
    {
        "section": str,
        "unit": int,
        "H": float,
        "t": float,
        "class": str | None,
        "reset_time": float | str | None,
        "inversion_pressure_MPa": float | str | None,
        "phase": str,
        "pressure_MPa": float,
    },
)


class CandidateRow(TypedDict):
    """A section design the search verified, with the leg's stride with it.

    Heights and ``t`` in mm; ``met``: every requirement of its section; ``stride`` in mm (None
    when not compared).
    """

    H: list[float]
    t: float
    met: bool
    stride: float | None


@dataclass(frozen=True)
class WalkerLegResult:
    """One designed leg of a walker scene, verified (the ``--json`` row of :meth:`to_dict`).

    Attributes
    ----------
    leg : str
        ``"front"`` or ``"middle"``.
    gait : GaitSpec
        The scene's gait (MPa, s).
    inversion_method : str
    evaluations : dict of str to int
    wall_s : float
        Seconds of the leg's search.
    reachable : bool
        Every requirement met.
    proof : str or None
        Which section was not found (then nothing else is set).
    designs : dict of str to Design
        The sections' designs (purple, green, action).
    units : list of UnitRow
        Each unit's verified class, reset time (s) and inversion pressure (MPa).
    requirements : list of Requirement
    walk, monostable, turn : LegResult or None
        The leg at the walking gait, the monostable leg at the same gait, the front leg at the
        turning gait (strides in mm).
    timing : dict of str to LegResult
        The runs of the timing diagrams.
    stride_ratio : float or None
    monostable_source : str
        The monostable leg's file or example name.
    verify_atol : float
        mm.
    candidates : dict of str to list of CandidateRow
        The purple zone's and action unit's candidates.
    """

    leg: str
    gait: GaitSpec
    inversion_method: str
    evaluations: dict[str, int]
    wall_s: float
    reachable: bool
    proof: str | None = None
    designs: dict[str, Design] = field(default_factory=dict)
    units: list[UnitRow] = field(default_factory=list)
    requirements: list[Requirement] = field(default_factory=list)
    walk: LegResult | None = None
    monostable: LegResult | None = None
    turn: LegResult | None = None
    timing: dict[str, LegResult] = field(default_factory=dict)
    stride_ratio: float | None = None
    monostable_source: str = ""
    verify_atol: float = 0.0
    candidates: dict[str, list[CandidateRow]] = field(default_factory=dict)

    @property
    def met(self) -> bool:
        """Every requirement of the leg met."""
        return self.reachable

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row."""
        row: dict[str, Any] = {
            "leg": self.leg,
            "target": self.leg,
            "gait": self.gait.to_dict(),
            "inversion_method": self.inversion_method,
            "evaluations": dict(self.evaluations),
            "wall_s": self.wall_s,
        }
        if self.proof is not None:
            row.update(
                {
                    "reachable": False,
                    "design": None,
                    "objective": None,
                    "stride": None,
                    "fitted_range": None,
                    "fitted_range_note": None,
                    "proof": self.proof,
                }
            )
            return row
        walk, mono = self.walk, self.monostable
        notes = [
            f"{role}: {self.designs[role].fitted_range_note}"
            for role in _ROLES
            if not self.designs[role].in_fitted_range
        ]
        row.update(
            {
                "reachable": self.reachable,
                "objective": violation(self.requirements),
                "design": {role: self.designs[role].to_dict() for role in _ROLES},
                "heights": {role: list(self.designs[role].H) for role in _ROLES},
                "units": self.units,
                "requirements": [
                    {**r, "value": _value(r["value"]), "bound": _value(r["bound"])}
                    for r in self.requirements
                ],
                "requirements_met": all(r["met"] for r in self.requirements),
                "stride": walk.stride,
                "extent": walk.extent.tolist(),
                "monostable_stride": mono.stride,
                "monostable_extent": mono.extent.tolist(),
                "stride_ratio": json_number(self.stride_ratio),
                "monostable_leg": self.monostable_source,
                "monostable_sections": [
                    {
                        "name": r.section.name,
                        "H": list(r.section.design.H),
                        "t": r.section.design.t,
                        "classes": list(r.result.unit_class),
                        "reset_times": json_times(r.result.reset_time),
                    }
                    for r in mono.sections
                ],
                "fitted_range": not notes,
                "fitted_range_note": "; ".join(notes) or None,
                "verification": {
                    "method": VERIFIED_BY.format(atol=self.verify_atol),
                    "sections": "each under the phase of its requirement; the leg composed "
                    "from section runs at the leg's own tolerance",
                },
                "tip_path": _path_rows(walk),
                "monostable_tip_path": _path_rows(mono),
            }
        )
        if self.leg == "front":
            turn = self.turn
            action_run = turn.sections[2].result
            row["turning"] = {
                "stride": turn.stride,
                "extent": turn.extent.tolist(),
                "action_inverts": action_run.unit_class[0] is not None,
                "action_inverted_at_end": bool(np.isinf(action_run.reset_time[0])),
                "t_end": turn.leg.t_end,
                "tip_path": _path_rows(turn),
            }
            diagnostic = self.timing.get("turn")
            if diagnostic is not None:  # the timing figure's run: longer than the stride run
                row["turning"]["timing_figure_t_end"] = float(diagnostic.leg.t_end)
        row["candidates"] = self.candidates
        return row


def walker_report(
    spec: SceneSpec[WalkerSpec], result: LegOutcome, evaluator: SceneEvaluator
) -> WalkerLegResult:
    """The verified result of one designed leg."""
    w = spec.kind_spec
    kind = result.kind
    facts = dict(
        leg=kind,
        gait=w.gait,
        inversion_method=result.inversion_method,
        evaluations=dict(result.counts),
        wall_s=result.wall_s,
    )
    purple, green, action = result.purple["best"], result.green, result.action["best"]
    if purple is None or action is None:
        missing = "purple zone" if purple is None else "action unit"
        return WalkerLegResult(
            **facts,
            reachable=False,
            proof=f"no {missing} meeting its timing was found on the t lines "
            f"searched ({w.t_lines})",
        )
    parts = {"purple": purple, "green": green, "action": action}
    profiles = {
        "purple": ("phase 1", w.gait.walk_pressure),
        "green": ("phase 2", w.gait.walk_pressure),
        "action": (
            "phase 2",
            w.gait.turn_pressure if kind == "front" else w.gait.walk_pressure,
        ),
    }
    units: list[UnitRow] = []
    for role in _ROLES:
        d, check, p_inv = parts[role]["design"], parts[role]["check"], parts[role]["inversion"]
        for k in range(d.n_units):
            units.append(
                {
                    "section": role,
                    "unit": k + 1,
                    "H": d.H[k],
                    "t": d.t,
                    "class": check["classes"][k],
                    "reset_time": json_times([check["reset"][k]])[0],
                    "inversion_pressure_MPa": json_number(p_inv[k]),
                    "phase": profiles[role][0],
                    "pressure_MPa": profiles[role][1],
                }
            )
    candidates = {
        role: [
            {
                "H": list(c["design"].H),
                "t": c["design"].t,
                "met": all(r["met"] for r in c.get("requirements", [])),
                "stride": c.get("stride"),
            }
            for c in getattr(result, role)["candidates"]
        ]
        for role in ("purple", "action")
    }
    return WalkerLegResult(
        **facts,
        reachable=bool(result.reachable),
        designs={role: parts[role]["design"] for role in _ROLES},
        units=units,
        requirements=list(result.requirements),
        walk=result.walk,
        monostable=result.monostable,
        turn=result.turn,
        timing=result.timing,
        stride_ratio=result.stride_ratio,
        monostable_source=w.monostable_source,
        verify_atol=w.verify_atol,
        candidates=candidates,
    )


def inverted_intervals(result, t_end: float) -> list[list[tuple[float, float]]]:
    """Each unit's inverted intervals ``(t_on, t_off)`` (s) from a simulation's crossings."""
    n = result.design.n_units
    out: list[list[tuple[float, float]]] = [[] for _ in range(n)]
    on = [math.nan] * n
    for t, unit, direction in result.events:
        k = int(unit) - 1
        if direction > 0 and math.isnan(on[k]):
            on[k] = float(t)
        elif direction < 0 and not math.isnan(on[k]):
            out[k].append((on[k], float(t)))
            on[k] = math.nan
    for k in range(n):
        if not math.isnan(on[k]):
            out[k].append((on[k], t_end))
    return out


def _write_leg(path: Path, row: Mapping[str, Any], spec: SceneSpec[WalkerSpec], title: str) -> Path:
    """Write the designed leg as a leg file (``dpfexplore simulate-leg``), read back checked."""
    g = spec.kind_spec.gait
    comments = [
        title,
        "Written by dpfexplore design: run it with dpfexplore simulate-leg "
        "(the walking gait, one cycle).",
    ]
    if spec.constants != DEFAULT:
        comments.append(f"under constants set {spec.constants.label}, saved beside this file")
    comments += [
        "Result (not read by simulate-leg): "
        f"stride {row['stride']:.4f} mm, {row['stride_ratio']:.3f} x the monostable "
        f"leg's ({row['monostable_stride']:.4f} mm); requirements met: "
        f"{row['requirements_met']}; fitted range: {row['fitted_range']}"
    ]
    sections = []
    for role, phase in (("purple", "1"), ("green", "2"), ("action", "2")):
        d = {k: v for k, v in row["design"][role].items() if k != "name"}
        if spec.constants != DEFAULT:
            d["constants"] = CONSTANTS_FILE
        sections.append({"name": role, "phase": phase, "design": d})
    document = {
        "leg": {"composition": "dpw", "t_end": g.t_end, "n_samples": 501},
        "phase": {
            "1": {"P0": g.walk_pressure, "tau": list(g.phase1)},
            "2": {"P0": g.walk_pressure, "tau": list(g.phase2)},
        },
        "section": sections,
    }
    return write_toml(path, document, comments, kind="leg")


def write_walker_report(
    spec: SceneSpec[WalkerSpec],
    results: list[WalkerLegResult],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Summary, history, leg TOMLs and, with ``plot``, tip paths and timing diagrams (paths).

    Writes into ``out`` as it stands: :func:`dpfexplore.inverse.design.run_design` passes the
    staging directory of :func:`dpfexplore.io.result_dirs.result_directory`, so the
    report appears complete or not at all.
    """
    out = Path(out)
    rows = [r.to_dict() for r in results]
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s)
    for row in rows:
        if row.get("design") is None:
            continue
        path = out / f"leg-{row['leg']}.toml"
        _write_leg(path, row, spec, f"{spec.name}: designed {row['leg']} leg")
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _figures(spec, results, rows, out)
    return written


def _figures(
    spec: SceneSpec[WalkerSpec], results: list[WalkerLegResult], rows, out: Path
) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")

    paths = []
    g = spec.kind_spec.gait
    for result, row in zip(results, rows, strict=True):
        if result.walk is None:
            continue
        kind = row["leg"]
        runs = [result.walk, result.monostable]
        labels = [f"designed {kind} leg, walking", "monostable leg, same gait"]
        if result.turn is not None:
            runs.insert(1, result.turn)
            labels.insert(1, f"designed {kind} leg, turning (phase 2 raised)")
        title = (
            f"{spec.name}: {kind} leg, stride {row['stride']:.2f} mm vs "
            f"{row['monostable_stride']:.2f} mm (monostable)"
        )
        path = out / f"tip-path-{kind}.png"
        tip_path_figure(runs, labels, title).savefig(path, dpi=120)
        paths.append(path)
        for mode, leg in result.timing.items():
            phases = [(f"phase {s}", leg.t, leg.leg.phases[s](leg.t)) for s in ("1", "2")]
            units = []
            for run in leg.sections:
                intervals = inverted_intervals(run.result, leg.t[-1])
                for k in range(run.section.design.n_units):
                    cls = next(
                        u["class"]
                        for u in row["units"]
                        if u["section"] == run.section.name and u["unit"] == k + 1
                    )
                    if cls == "no_contact":
                        intervals[k] = []
                    label = f"{run.section.name} {k + 1}"
                    if not intervals[k] and cls not in (None, "no_contact"):
                        label += ", flat here"  # its class is that under its requirement's phase
                    units.append((label, intervals[k], cls))
            marks = [(c * g.period, f"cycle {c + 1}") for c in range(g.cycles)]
            what = "walking" if mode == "walk" else "turning: phase 2 raised in cycle 1"
            fig = timing_figure(
                phases,
                units,
                t_end=float(leg.t[-1]),
                marks=marks,
                title=f"{kind} leg, {what} ({g.cycles} cycles)",
            )
            path = out / f"timing-{kind}-{mode}.png"
            fig.savefig(path, dpi=120)
            paths.append(path)
    return paths


def tip_path_figure(runs, labels: list[str], title: str):
    """``tip-path-KIND.png``: the runs' tip paths (:func:`plot_tip_paths`) under ``title``."""
    from matplotlib.figure import Figure

    from ....plotting.leg import plot_tip_paths

    fig = Figure(figsize=(12, 5), layout="constrained")
    plot_tip_paths(runs, fig.subplots(1, 2), labels=labels)
    fig.suptitle(title)
    return fig


def timing_figure(phases, units, *, t_end: float, marks, title: str):
    """``timing-KIND-MODE.png``: one leg's timing diagram (:func:`plot_gait_timing`'s arguments)."""
    from matplotlib.figure import Figure

    from ....plotting.timing import plot_gait_timing

    fig = Figure(figsize=(11, 4.5), layout="constrained")
    plot_gait_timing(phases, units, t_end=t_end, marks=marks, ax=fig.subplots(), title=title)
    return fig
