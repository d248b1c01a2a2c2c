"""The walker-leg scene's verified rows and files (leg TOMLs, tip paths, gait timing diagrams).

A row (``--json``) per designed leg: each section's design, each unit's class, reset time and
inversion pressure (from the verification runs of :mod:`.walker_design`, at ``verify_atol``),
every requirement with its value, bound and whether it is met, the stride at the walking gait
against the monostable leg's at the same gait, the tip path, the fitted-range flag.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ....lookup.files import CONSTANTS_FILE, toml_value, write_constants_beside
from ....model.constants_set import DEFAULT
from ....model.formatting import json_number
from ...engine.optimiser import TargetResult
from ...evaluation import SceneEvaluator
from ...report import TIMING_VERIFIED_BY as VERIFIED_BY
from ...report import json_times, write_summary
from .solve import violation

__all__ = ["inverted_intervals", "walker_report", "write_walker_report"]

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


def walker_report(spec, result: TargetResult, evaluator: SceneEvaluator) -> dict[str, Any]:
    """The verified ``--json`` row of one designed leg."""
    extra = result.extra
    kind = extra["kind"]
    row: dict[str, Any] = {
        "leg": kind,
        "target": kind,
        "gait": spec.walker.gait.to_dict(),
        "inversion_method": extra["inversion_method"],
        "evaluations": dict(result.counts),
        "wall_s": result.wall_s,
    }
    purple, green, action = extra["purple"]["best"], extra["green"], extra["action"]["best"]
    if purple is None or action is None:
        missing = "purple zone" if purple is None else "action unit"
        row.update(
            {
                "reachable": False,
                "design": None,
                "objective": None,
                "stride": None,
                "fitted_range": None,
                "fitted_range_note": None,
                "proof": f"no {missing} meeting its timing was found on the t lines "
                f"searched ({spec.walker.t_lines})",
            }
        )
        return row
    parts = {"purple": purple, "green": green, "action": action}
    profiles = {
        "purple": ("phase 1", spec.walker.gait.walk_pressure),
        "green": ("phase 2", spec.walker.gait.walk_pressure),
        "action": (
            "phase 2",
            spec.walker.gait.turn_pressure if kind == "front" else spec.walker.gait.walk_pressure,
        ),
    }
    units = []
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
    walk, mono = extra["walk"], extra["monostable"]
    requirements = [
        {**r, "value": _value(r["value"]), "bound": _value(r["bound"])}
        for r in extra["requirements"]
    ]
    notes = [
        f"{role}: {parts[role]['design'].fitted_range_note}"
        for role in _ROLES
        if not parts[role]["design"].in_fitted_range
    ]
    row.update(
        {
            "reachable": bool(result.reachable),
            "objective": violation(extra["requirements"]),
            "design": {role: parts[role]["design"].to_dict() for role in _ROLES},
            "heights": {role: list(parts[role]["design"].H) for role in _ROLES},
            "units": units,
            "requirements": requirements,
            "requirements_met": all(r["met"] for r in extra["requirements"]),
            "stride": walk.stride,
            "extent": walk.extent.tolist(),
            "monostable_stride": mono.stride,
            "monostable_extent": mono.extent.tolist(),
            "stride_ratio": json_number(extra["stride_ratio"]),
            "monostable_leg": spec.walker.monostable_source,
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
                "method": VERIFIED_BY.format(atol=spec.walker.verify_atol),
                "sections": "each under the phase of its requirement; the leg composed "
                "from section runs at the leg's own tolerance",
            },
            "tip_path": _path_rows(walk),
            "monostable_tip_path": _path_rows(mono),
        }
    )
    if kind == "front":
        turn = extra["turn"]
        action_run = turn.sections[2].result
        row["turning"] = {
            "stride": turn.stride,
            "extent": turn.extent.tolist(),
            "action_inverts": action_run.unit_class[0] is not None,
            "action_inverted_at_end": bool(np.isinf(action_run.reset_time[0])),
            "t_end": turn.leg.t_end,
            "tip_path": _path_rows(turn),
        }
        diagnostic = extra.get("timing", {}).get("turn")
        if diagnostic is not None:  # the timing figure's run: longer than the stride run
            row["turning"]["timing_figure_t_end"] = float(diagnostic.leg.t_end)
    row["candidates"] = {
        role: [
            {
                "H": list(c["design"].H),
                "t": c["design"].t,
                "met": all(r["met"] for r in c.get("requirements", [])),
                "stride": c.get("stride"),
            }
            for c in extra[role]["candidates"]
        ]
        for role in ("purple", "action")
    }
    row["_legs"] = {
        "walk": walk,
        "monostable": mono,
        "turn": extra.get("turn"),
        "timing": extra["timing"],
    }
    return row


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


def _leg_toml(row: dict[str, Any], spec, title: str) -> str:
    g = spec.walker.gait
    lines = [
        f"# {title}",
        "# Written by dpfexplore design: run it with dpfexplore simulate-leg "
        "(the walking gait, one cycle).",
        "",
        "[leg]",
        'composition = "dpw"',
    ]
    if spec.constants != DEFAULT:
        lines[2:2] = [f"# under constants set {spec.constants.label}, saved beside this file"]
    lines += [
        f"t_end = {g.t_end!r}",
        "n_samples = 501",
        "",
        "[phase.1]",
        f"P0 = {g.walk_pressure!r}",
        f"tau = {toml_value(list(g.phase1))}",
        "",
        "[phase.2]",
        f"P0 = {g.walk_pressure!r}",
        f"tau = {toml_value(list(g.phase2))}",
    ]
    for role, phase in (("purple", "1"), ("green", "2"), ("action", "2")):
        d = dict(row["design"][role])
        if spec.constants != DEFAULT:
            d["constants"] = CONSTANTS_FILE
        body = ", ".join(f"{k} = {toml_value(v)}" for k, v in d.items() if k != "name")
        lines += [
            "",
            "[[section]]",
            f'name = "{role}"',
            f'phase = "{phase}"',
            f"design = {{ {body} }}",
        ]
    lines += ["", "# Result (not read by simulate-leg):"]
    lines += [
        f"# stride {row['stride']:.4f} mm, {row['stride_ratio']:.3f} x the monostable "
        f"leg's ({row['monostable_stride']:.4f} mm); requirements met: "
        f"{row['requirements_met']}; fitted range: {row['fitted_range']}"
    ]
    return "\n".join(lines) + "\n"


def write_walker_report(
    spec,
    rows: list[dict[str, Any]],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Summary, history, leg TOMLs and, with ``plot``, tip paths and timing diagrams (paths).

    Writes into ``out`` as it stands: :func:`dpfexplore.inverse.design.run_design` passes the
    staging directory of :func:`dpfexplore.sweep.storage.result_dirs.result_directory`, so the
    report appears complete or not at all.
    """
    out = Path(out)
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s)
    for row in rows:
        if row.get("design") is None:
            continue
        path = out / f"leg-{row['leg']}.toml"
        path.write_text(_leg_toml(row, spec, f"{spec.name}: designed {row['leg']} leg"))
        written.append(path)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _figures(spec, rows, out)
    return written


def _figures(spec, rows, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ....plotting.leg import plot_tip_paths
    from ....plotting.timing import plot_gait_timing

    paths = []
    g = spec.walker.gait
    for row in rows:
        legs = row.get("_legs")
        if not legs:
            continue
        kind = row["leg"]
        results = [legs["walk"], legs["monostable"]]
        labels = [f"designed {kind} leg, walking", "monostable leg, same gait"]
        if legs.get("turn") is not None:
            results.insert(1, legs["turn"])
            labels.insert(1, f"designed {kind} leg, turning (phase 2 raised)")
        fig, axes = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")
        plot_tip_paths(results, axes, labels=labels)
        fig.suptitle(
            f"{spec.name}: {kind} leg, stride {row['stride']:.2f} mm vs "
            f"{row['monostable_stride']:.2f} mm (monostable)"
        )
        path = out / f"tip-path-{kind}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
        for mode, leg in legs["timing"].items():
            fig, ax = plt.subplots(figsize=(11, 4.5), layout="constrained")
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
            plot_gait_timing(
                phases,
                units,
                t_end=float(leg.t[-1]),
                marks=marks,
                ax=ax,
                title=f"{kind} leg, {what} ({g.cycles} cycles)",
            )
            path = out / f"timing-{kind}-{mode}.png"
            fig.savefig(path, dpi=120)
            plt.close(fig)
            paths.append(path)
    return paths
