"""Verified answers of a scene and the files ``dpfexplore design`` writes.

Nothing the optimiser found is reported as it stands: every reported design (the best design of
each target, each point of a front, the weighted-sum design, the gripper) is re-solved on its
own by :func:`dpfexplore.solvers.statics.find_state` with the default solver options, and the
tip, objective, stiffness and apertures reported are those of that re-solve; the report says so
in each result's ``"verification"``. A design outside the range the closed forms were fitted on
(MODEL.md §3) is flagged (``"fitted_range": false`` with a note).

Files (:func:`write_report`)
    ``summary.json``          the scene, every result (the ``--json`` shape), evaluation counts
    ``history.parquet``       every evaluated design: parameters, purpose, objective parts,
                              status (read with :func:`pandas.read_parquet`)
    ``target-KK.toml``        the best design of target KK as a ``[design]`` table
                              (``dpfexplore states`` reads it back) with a ``[result]`` table
    ``gripper.toml``          the gripper's design, its base and its apertures
    ``*.png``                 with ``plot=True``: the finger in each targeted state with its
                              target, the objective against evaluations, the front, and the
                              reachable region of unreachable targets

The writers fill the directory they are given; ``dpfexplore design`` gives them a staging
directory that replaces ``--out`` whole once everything is written
(:func:`dpfexplore.sweep.storage.result_dirs.result_directory`, manifest
``.dpfexplore-result.json``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..lookup.files import design_toml as write_design_toml
from ..lookup.files import write_constants_beside
from ..model.design import Design
from ..model.formatting import json_number
from ..model.gripper import gripper_aperture
from ..solvers.lattice import spring_constants
from ..solvers.statics import find_state
from .engine.optimiser import TargetResult
from .evaluation import SceneEvaluator
from .scenes.gripper.windows import pressure_windows

__all__ = ["gripper_report", "position_report", "write_report"]

#: How the timing scenes (pick-and-place, walker) verify a reported design's reset times.
TIMING_VERIFIED_BY = (
    "simulated alone to the horizon (no early stop) by the full model (rodas4) at "
    "atol = {atol:g} mm; the reported reset times and classes are this run's"
)


def json_times(values) -> list:
    """Reset times for JSON: ``"inf"`` never reset, None never inverted or no contact."""
    out = []
    for v in values:
        v = float(v)
        out.append(None if math.isnan(v) else ("inf" if math.isinf(v) else round(v, 9)))
    return out


_VERIFIED_BY = (
    "re-solved alone by find_state (exact model, default solver options); the "
    "reported values are this re-solve's"
)


def _verify(design: Design, state: str, evaluator: SceneEvaluator) -> dict[str, Any]:
    result = find_state(design, state)
    evaluator.count("verifications")
    return {
        "stable": result.stable,
        "status": result.status.label,
        "found": result.found,
        "tip": [float(result.tip[0]), float(result.tip[1])],
        "stiffness": float(result.stiffness),
        "min_eig": float(result.min_eig),
        "nodes": result.nodes,
    }


def _design_entry(design: Design, state: str, target, evaluator: SceneEvaluator) -> dict[str, Any]:
    """A design with its verified tip, objective and stiffness."""
    check = _verify(design, state, evaluator)
    tip = np.array(check["tip"])
    objective = float(np.sum((tip - np.asarray(target)) ** 2)) if check["stable"] else math.inf
    inside, note = bool(design.in_fitted_range), design.fitted_range_note
    return {
        "design": design.to_dict(),
        "n_units": design.n_units,
        "state": state,
        "tip": check["tip"],
        "objective": json_number(objective),
        "distance_mm": json_number(math.sqrt(objective)),
        "stiffness": json_number(check["stiffness"]),
        "fitted_range": inside,
        "fitted_range_note": note,
        "verification": {
            "method": _VERIFIED_BY,
            "status": check["status"],
            "stable": check["stable"],
            "min_eig": json_number(check["min_eig"]),
        },
        "_nodes": check["nodes"],
    }


def position_report(spec, result: TargetResult, evaluator: SceneEvaluator) -> dict[str, Any]:
    """The verified report of one position target (the ``--json`` row)."""
    target = spec.targets[result.target_index]
    best = result.best
    design = best.problem.designs(np.atleast_2d(best.z)).design(0)
    state = best.problem.state_bits
    entry = _design_entry(design, state, target.point, evaluator)
    reachable = (
        entry["verification"]["stable"]
        and entry["objective"] is not None
        and entry["objective"] <= spec.tolerance
    )
    row: dict[str, Any] = {
        "target": list(target.point),
        "reachable": bool(reachable),
        **entry,
        "evaluations": dict(result.counts),
        "wall_s": result.wall_s,
        "best_objective_per_n": {str(n): json_number(v) for n, v in result.per_n.items()},
    }
    if not reachable:
        row["nearest_tip"] = entry["tip"]
        row["proof"] = (
            f"{spec.optimiser.starts_per_n} gradient refinements per N from the best distinct of "
            f"{spec.optimiser.candidates_per_n} Latin-hypercube candidates per N all stopped above "
            f"the tolerance {spec.tolerance:g} mm²; best objective per N in "
            "best_objective_per_n, every evaluated tip in history.parquet"
        )
    if result.front:
        row["front"] = []
        for point in result.front:
            if point.z is None:
                row["front"].append({"tolerance_mm": point.tolerance, "design": None})
                continue
            d = point.problem.designs(np.atleast_2d(point.z)).design(0)
            e = _design_entry(d, point.problem.state_bits, target.point, evaluator)
            e.pop("_nodes")
            row["front"].append({"tolerance_mm": point.tolerance, **e})
    if result.weighted is not None:
        w = result.weighted
        d = w.problem.designs(np.atleast_2d(w.z)).design(0)
        e = _design_entry(d, w.problem.state_bits, target.point, evaluator)
        e.pop("_nodes")
        row["weighted"] = {"weights": list(spec.weights), **e}
    if target.reference is not None:
        ref = _design_entry(
            target.reference, "1" * target.reference.n_units, target.point, evaluator
        )
        ref.pop("_nodes")
        row["reference"] = ref
        row["dominates_reference"] = _dominating(row, ref)
    return row


def _dominating(row: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any] | None:
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
            return {
                "tolerance_mm": p["tolerance_mm"],
                "distance_mm": p["distance_mm"],
                "stiffness": p["stiffness"],
                "stiffness_ratio": p["stiffness"] / ref["stiffness"],
            }
    return None


def _gripper_entry(
    design: Design, g, theta: float, base_l: float, evaluator: SceneEvaluator
) -> dict:
    h = float(spring_constants(design).h)
    apertures, stiffness, statuses, nodes = [], math.nan, [], []
    for state in dict.fromkeys([*g.states, g.activated]):
        check = _verify(design, state, evaluator)
        statuses.append(check["status"])
        if state in g.states:
            apertures.append(float(gripper_aperture(check["tip"], h, base_l, theta)))
            nodes.append(check["nodes"])
        if state == g.activated:
            stiffness = check["stiffness"]
    errors = [a - t for a, t in zip(apertures, g.apertures, strict=True)]
    inside, note = bool(design.in_fitted_range), design.fitted_range_note
    return {
        "design": design.to_dict(),
        "n_units": design.n_units,
        "theta_B_deg": theta,
        "base_L": base_l,
        "apertures": apertures,
        "aperture_errors": errors,
        "stiffness": json_number(stiffness),
        "state": g.activated,
        "objective": float(np.sum(np.square(errors))),
        "fitted_range": inside,
        "fitted_range_note": note,
        "verification": {
            "method": _VERIFIED_BY,
            "status": statuses,
            "stable": all(s == "ok" for s in statuses),
        },
        "_nodes": nodes,
        "_h": h,
    }


def gripper_report(spec, result: TargetResult, evaluator: SceneEvaluator) -> dict[str, Any]:
    """The verified report of the gripper scene (the ``--json`` row)."""
    from .scenes.gripper.solve import metastability, windows_ok

    g = spec.gripper
    best = result.best
    design = best.problem.designs(np.atleast_2d(best.z)).design(0)
    theta, base_l = (float(v[0]) for v in best.problem.base(np.atleast_2d(best.z)))
    entry = _gripper_entry(design, g, theta, base_l, evaluator)
    windows = result.extra.get("windows", {})
    checks = result.extra.get("metastability", {})
    met = (
        entry["verification"]["stable"]
        and max(abs(e) for e in entry["aperture_errors"]) <= g.aperture_tol
    )
    window_ok = windows_ok(windows, g.min_window_kPa) if windows.get("computed") else None
    row: dict[str, Any] = {
        "target": list(g.apertures),
        "reachable": bool(met),
        **entry,
        "pressure_windows_kPa": windows.get("windows"),
        "pressure_windows_kPa_detail": windows,
        "windows_ok": window_ok,
        "metastability": checks,
        "evaluations": dict(result.counts),
        "wall_s": result.wall_s,
    }
    if g.reference is not None and g.reference_theta_B_deg is not None:
        ref = _gripper_entry(g.reference, g, g.reference_theta_B_deg, g.reference_base_L, evaluator)
        ref.pop("_nodes")
        ref.pop("_h")
        ref["metastability"] = metastability(g.reference, g, evaluator)
        ref["pressure_windows_kPa"] = pressure_windows(g.reference, g.states, evaluator)["windows"]
        row["reference"] = ref
        if ref["stiffness"] is not None and entry["stiffness"] is not None:
            row["stiffness_ratio_to_reference"] = entry["stiffness"] / ref["stiffness"]
    return row


# ----------------------------------------------------------------------------- files


def result_row_toml(row: dict[str, Any], *, title: str, constants=None) -> str:
    """A ``[design]`` table (read back by ``dpfexplore states``) and a ``[result]`` table.

    ``constants``: the scene's set, named in the file when it is not the paper's.
    """
    keys = (
        "state",
        "target",
        "tip",
        "objective",
        "stiffness",
        "apertures",
        "theta_B_deg",
        "base_L",
        "reachable",
        "fitted_range",
        "fitted_range_note",
    )
    return write_design_toml(
        row["design"],
        [title, "Written by dpfexplore design; [design] is read by dpfexplore states."],
        {key: row.get(key) for key in keys},
        constants=constants,
    )


def public(row: dict[str, Any]) -> dict[str, Any]:
    """A result row without its private drawing data (keys starting with ``_``)."""
    return {k: v for k, v in row.items() if not k.startswith("_")}


def write_summary(
    spec,
    rows: list[dict[str, Any]],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    history=None,
) -> list[Path]:
    """Write ``summary.json`` and ``history.parquet`` in ``out``; returns their paths.

    The summary holds the scene, the results, the evaluations by kind and the wall time; the
    history every evaluated design (``history``: :meth:`SceneEvaluator.history`, if the caller
    has it).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        "scene": spec.document,
        "kind": spec.kind,
        "name": spec.name,
        "constants": {"name": spec.constants.name, "fingerprint": spec.constants.fingerprint},
        "results": [public(r) for r in rows],
        "evaluations": dict(evaluator.counts),
        "wall_s": wall_s,
    }
    path = out / "summary.json"
    path.write_text(json.dumps(summary, indent=2, default=_json_default) + "\n")
    history_path = out / "history.parquet"
    (evaluator.history() if history is None else history).to_parquet(history_path, index=False)
    return [path, history_path]


def write_report(
    spec,
    rows: list[dict[str, Any]],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Write summary, history, design TOMLs and (optionally) figures; returns the paths.

    Writes into ``out`` as it stands (a file of an earlier run there would stay):
    :func:`dpfexplore.inverse.design.run_design` passes the staging directory of
    :func:`dpfexplore.sweep.storage.result_dirs.result_directory`, so ``dpfexplore design --out
    DIR`` is complete or absent and holds only this run's files.
    """
    out = Path(out)
    history = evaluator.history()
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s, history=history)
    for i, row in enumerate(rows):
        if spec.kind == "gripper":
            path = out / "gripper.toml"
            title = f"{spec.name}: gripper, apertures {row['target']} mm"
        else:
            path = out / f"target-{i + 1:02d}.toml"
            title = f"{spec.name}: target {i + 1} {row['target']} mm"
        path.write_text(result_row_toml(row, title=title, constants=spec.constants))
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _figures(spec, rows, history, out)
    return written


def _json_default(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _figures(spec, rows, history, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plotting.design import (
        plot_front,
        plot_gripper,
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
    if spec.kind == "gripper":
        row = rows[0]
        save(
            plot_gripper(
                row["_nodes"],
                row["_h"],
                row["theta_B_deg"],
                row["base_L"],
                row["target"],
                row["apertures"],
                states=list(spec.gripper.states),
            ),
            "gripper.png",
        )
        return paths
    save(
        plot_target_shapes(
            [r["_nodes"] for r in rows], [r["target"] for r in rows], [r["reachable"] for r in rows]
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
