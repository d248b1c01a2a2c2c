"""Verified answers of the timing scenes (pick-and-place, walker leg) and the files they write.

Every design reported here was re-simulated alone in the full model (Rodas4) over its whole
horizon (no early stop) at the scene's ``verify_atol``; the reset times, classes and final states
reported are that run's. Grasp stiffnesses are :func:`dpfexplore.solvers.statics.find_state`
re-solves. Units whose reach ``d`` is clamped are classed ``no_contact``. Every design carries
``fitted_range`` and ``fitted_range_note`` (:attr:`dpfexplore.model.design.Design.in_fitted_range`).

Files (:func:`write_timing_report`; the walker's :func:`.walker_report.write_walker_report`)
    ``summary.json``, ``history.parquet``   as :func:`dpfexplore.inverse.report.write_report`
    ``result-KK.toml``     pick-and-place: the design of result KK (``[design]``, read by
                           ``dpfexplore states`` and ``dpfexplore simulate``) and ``[result]``
    ``leg-<kind>.toml``    walker: the designed leg as a leg file (``dpfexplore simulate-leg``)
    ``*.png``              with ``plot=True``: pick-and-place reset map with the designs and the
                           difference front; walker tip paths against the monostable leg and the
                           gait timing diagrams
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ....lookup.files import design_toml, write_constants_beside
from ....model.design import Design
from ....model.formatting import json_number
from ....solvers.statics import find_state
from ...engine.optimiser import TargetResult
from ...evaluation import SceneEvaluator
from ...report import TIMING_VERIFIED_BY as VERIFIED_BY
from ...report import json_times, write_summary

__all__ = ["pickplace_report", "write_timing_report"]


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


def _grasp(design: Design, state: str, evaluator: SceneEvaluator) -> dict[str, Any]:
    result = find_state(design, state)
    evaluator.count("verifications")
    return {
        "stiffness": json_number(result.stiffness) if result.stable else None,
        "status": result.status.label,
        "stable": bool(result.stable),
    }


def _check_entry(check: dict) -> dict[str, Any]:
    return {
        "reset_times": json_times(check["reset_times"]),
        "classes": check["classes"],
        "final_state": check["final_state"],
        "objective_unit": check["objective_unit"],
        "reset_time": json_number(check["value"]),
    }


def pickplace_report(spec, result: TargetResult, evaluator: SceneEvaluator) -> dict[str, Any]:
    """The verified ``--json`` row of one pick-and-place result (target, unit pair or front)."""
    from .screen import reachable_range, screen_pickplace

    p = spec.pickplace
    extra = result.extra
    ranges = reachable_range(spec, evaluator)
    screen = screen_pickplace(spec, evaluator)
    common = {
        "objective_kind": extra["kind"],
        "reset_unit": p.reset_unit,
        "grasp_state": p.grasp_state,
        "profile": p.pulse.to_dict(),
        "reachable_range": ranges,
        "screening": {
            "method": screen.method,
            "note": screen.note,
            "designs": len(screen.ev.z),
            "wall_s": screen.wall_s,
        },
        "evaluations": dict(result.counts),
        "wall_s": result.wall_s,
    }
    best = extra["best"]
    if extra["kind"] == "difference":
        return {**_difference_row(spec, extra, evaluator), **common}
    row: dict[str, Any] = {"target": extra["target"], "target_reset": extra["target"]}
    if extra["kind"] == "unit_target":
        row["target_units"] = extra["units"]
    if best is None:
        row.update(
            UNREACHED,
            proof="no admissible design of the screening grid brackets the target and none is "
            "near it",
        )
        return {**row, **common}
    design, check = best["design"], best["check"]
    grasp = _grasp(design, p.grasp_state, evaluator)
    reachable = bool(best["error"] <= p.tolerance and check["admissible"])
    row.update(
        {
            "reachable": reachable,
            **design_flags(design),
            **_check_entry(check),
            "relative_error": json_number(best["error"]),
            "objective": json_number(best["error"]),
            "stiffness": grasp["stiffness"],
            "verification": {
                "method": VERIFIED_BY.format(atol=check["atol"]),
                "atol": check["atol"],
                "status": check["status"],
                "t_end": check["t_end"],
                "grasp_state": grasp["status"],
            },
            "search": {
                "brackets": extra.get("brackets"),
                "tried": len(extra["attempts"]),
                "root_evaluations": best.get("root_evaluations"),
            },
            "wall_s_note": "the target's search and verification; the screening and the reachable "
            "range of the scene are in screening.wall_s and reachable_range.wall_s "
            "(shared by every result of the run; the first result's wall_s includes "
            "its first stage)",
        }
    )
    if extra["kind"] == "unit_target":
        row["unit_errors"] = [json_number(e) for e in best["unit_errors"]]
        row["alternatives"] = [
            {
                "H": list(a["design"].H),
                "t": a["design"].t,
                "fitted_range": bool(a["design"].in_fitted_range),
                "reset_times": json_times(a["check"]["reset_times"]),
                "unit_errors": [json_number(e) for e in a["unit_errors"]],
            }
            for a in extra["attempts"]
            if a is not best
        ]
    if not reachable:
        row["nearest"] = {
            "reset_time": json_number(check["value"]),
            "relative_error": json_number(best["error"]),
        }
        row["proof"] = (
            f"{extra.get('brackets', 0)} bracket(s) of the target on the screening grid "
            f"({p.grid_t} x {p.grid_H}); {len(extra['attempts'])} closed on the full model, none "
            f"within {p.tolerance:g}; see reachable_range"
        )
    return {**row, **common}


def _difference_row(spec, extra: dict, evaluator: SceneEvaluator) -> dict[str, Any]:
    p = spec.pickplace
    d = p.difference

    def entry(q: dict) -> dict[str, Any]:
        c1, c2 = q["checks"]
        grasp = _grasp(q["design"], p.grasp_state, evaluator)
        return {
            **design_flags(q["design"]),
            "difference": json_number(q["difference"]),
            "stiffness": grasp["stiffness"],
            "reset_times": json_times(c1["reset_times"]),
            "reset_times_profile_2": json_times(c2["reset_times"]),
            "classes": c1["classes"],
            "classes_profile_2": c2["classes"],
            "reset_time": json_number(c1["value"]),
            "reset_time_profile_2": json_number(c2["value"]),
            "ok": bool(q["ok"]),
        }

    best = extra["best"]
    row: dict[str, Any] = {
        "target": None,
        "target_reset": None,
        "profiles": [p.pulse.to_dict(), d.pulse.to_dict()],
        "max_reset": d.max_reset,
    }
    if best is None:
        row.update(UNREACHED, front=[])
        return row
    main = entry(best)
    row.update(
        {
            "reachable": True,
            **main,
            "objective": main["difference"],
            "verification": {
                "method": VERIFIED_BY.format(atol=p.verify_atol),
                "atol": p.verify_atol,
            },
            "front": [entry(q) for q in extra["front"]],
            "lines": [
                {
                    "t": q["design"].t,
                    "H": list(q["design"].H),
                    "difference": json_number(q["difference"]),
                    "stiffness": json_number(q["stiffness"]),
                    "ok": bool(q["ok"]),
                }
                for q in extra["lines"]
            ],
        }
    )
    if extra.get("weighted") is not None:
        row["weighted"] = {"weights": list(d.weights), **entry(extra["weighted"])}
    return row


# ----------------------------------------------------------------------------- files


def _result_toml(row: dict[str, Any], title: str, constants=None) -> str:
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
    return design_toml(row["design"], comments, result, constants=constants)


def write_timing_report(
    spec,
    rows: list[dict[str, Any]],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Pick-and-place: summary, history, result TOMLs and (optionally) figures; the paths.

    Writes into ``out`` as it stands: :func:`dpfexplore.inverse.design.run_design` passes the
    staging directory of :func:`dpfexplore.sweep.storage.result_dirs.result_directory`, so the
    report appears complete or not at all.
    """
    out = Path(out)
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
        path.write_text(_result_toml(row, title, constants=spec.constants))
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _pickplace_figures(spec, rows, evaluator, evaluator.history(), out)
    return written


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def _target_label(row: dict[str, Any]) -> str:
    """A result row's target as the legend names it: its reset time, units or the front."""
    if row.get("target_units"):
        units = ", ".join(str(u) for u in row["target_units"])
        resets = ", ".join(f"{r:g}" for r in row.get("target_reset") or [])
        return f"units {units}: reset {resets} s"
    if row.get("target_reset") is not None:
        return f"reset {row['target_reset']:g} s"
    return "max RT_2 - RT_1"


def _pickplace_figures(spec, rows, evaluator: SceneEvaluator, history, out: Path) -> list[Path]:
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
            labels={i: _target_label(row) for i, row in enumerate(rows)},
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
