"""Pages of the documentation that are generated at build time, never typed by hand.

On ``builder-inited`` this Sphinx extension writes into ``docs/_generated/`` (git-ignored):

``benchmarks.md``
    The methodology prose of ``docs/_ext/templates/benchmarks.md`` with each ``{{ bench NAME }}``
    placeholder replaced by tables read from ``results/reports/bench-*.json`` (the records that
    ``dpfexplore bench NAME --save`` writes) and the machine and date each record ran on.
``gallery.md`` and ``gallery/*.png``
    Every ``docs/examples/*.py`` run in a subprocess with the output PNG path as its argument;
    the page shows each script's docstring, its figure and its source.
``tutorial.md`` and ``tutorial/*.png``
    ``docs/tutorial.ipynb`` as a Markdown page (its Markdown cells, its code cells as code
    blocks, and the text outputs and figures of its execution: :mod:`notebook_outputs`).
``api_public.rst``
    An autosummary table of ``dpfexplore.__all__``, each name under the module that defines it.

A failing example script or an unreadable record fails the build (``ExtensionError``).
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx
from sphinx.errors import ExtensionError
from sphinx.util import logging

LOG = logging.getLogger(__name__)

#: Seconds an example script may take before the build fails.
EXAMPLE_TIMEOUT_S = 120.0


# --------------------------------------------------------------------------- helpers


def _write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` unless the file already holds it (keeps incremental builds incremental)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def fmt(value: Any, digits: int = 3) -> str:
    """A number as the tables print it: ``digits`` significant figures, thousands separated.

    Integers and values of ``10**digits`` or more print whole, with thousands separators; others
    with ``digits`` significant figures (exponent notation below 1e-4).
    """
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        if math.isinf(value):
            return "∞" if value > 0 else "-∞"
        if value == 0:
            return "0"
        magnitude = abs(value)
        if magnitude >= 10**digits:
            return f"{value:,.0f}"
        return f"{value:.{digits}g}"
    return str(value)


def pct(value: float | None, digits: int = 3) -> str:
    """A fraction as a percentage."""
    return "–" if value is None else f"{fmt(100.0 * value, digits)} %"


def ratio(value: float | None, lower_bound: bool = False) -> str:
    """A speed-up or ratio, ``>=`` when it is a lower bound."""
    if value is None:
        return "–"
    return f"{'>= ' if lower_bound else ''}{fmt(value)}x"


def table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A Markdown pipe table; cells that are not strings go through :func:`fmt`."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        cells = [cell if isinstance(cell, str) else fmt(cell) for cell in row]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines) + "\n"


def _find_machine(record: Any) -> dict | None:
    """The first ``machine`` table in a record, searched breadth first."""
    queue = [record]
    while queue:
        node = queue.pop(0)
        if isinstance(node, dict):
            if isinstance(node.get("machine"), dict):
                return node["machine"]
            queue.extend(v for v in node.values() if isinstance(v, dict | list))
        elif isinstance(node, list):
            queue.extend(v for v in node if isinstance(v, dict | list))
    return None


def machine_line(record: dict, source: str) -> str:
    """Where and when a record ran, and the file it came from."""
    machine = _find_machine(record)
    where = f"Record `results/reports/{source}`"
    if machine is None:
        return where + " (no machine recorded).\n"
    parts = [
        f"{machine.get('cpu', '?')}, {machine.get('cores', '?')} cores",
        f"Python {machine.get('python', '?')}",
        f"NumPy {machine.get('numpy', '?')}",
        f"SciPy {machine.get('scipy', '?')}",
        f"Numba {machine.get('numba', '?')} ({machine.get('threading_layer', '?')} layer, "
        f"{machine.get('numba_threads', '?')} threads)",
    ]
    return (
        f"{where}: ran {machine.get('date', 'at an unrecorded date')} on "
        + ", ".join(parts)
        + ".\n"
    )


def compile_line(cold: float | None, cached: float | None) -> str:
    """Compile time, cold and from the cache, when the record has it."""
    if cold is None or (isinstance(cold, float) and math.isnan(cold)):
        return ""
    return f"\nCompile: {fmt(cold)} s cold (empty Numba cache), {fmt(cached)} s from the cache.\n"


def goal_cell(met: bool | None) -> str:
    """A goal's verdict."""
    return "–" if met is None else ("met" if met else "**not met**")


# --------------------------------------------------------------------------- benchmark renderers


def bench_statics(r: dict) -> str:
    """``bench statics``: time per design and tip errors per N."""
    rows = []
    for n in r["by_n_units"]:
        lo, hi = n["speedup_vs_paper"]
        rows.append(
            [
                n["n_units"],
                n["designs"],
                n["ours_us_per_design"],
                n["ours_us_per_design_p90"],
                n["ours_batch_mean_us_per_design"],
                n["ours_with_min_eig_us_per_design"],
                n["scipy_us_per_design"] / 1000.0,
                ratio(n["speedup_vs_scipy"]),
                ratio(n["speedup_vs_scipy_same_state"]),
                n["ours_tip_err_mm"],
                f"{fmt(n['scipy_tip_err_mm'])} ({n['scipy_same_state']})",
                n["ours_stiffness_rel_err"],
                n["designs_per_s_all_cores"],
                f"{fmt(lo)}–{fmt(hi)}x",
            ]
        )
    header = [
        "N",
        "designs",
        "ours, median µs",
        "p90 µs",
        "batch mean µs",
        "batch mean + smallest eigenvalue µs",
        "SciPy ms",
        "speed-up",
        "speed-up, same state",
        "ours tip error mm",
        "SciPy tip error mm (found the state)",
        "ours stiffness rel. error",
        f"designs/s, {r['threads_all_cores']} threads",
        "vs the paper's time per design",
    ]
    return table(header, rows) + compile_line(r.get("compile_s"), r.get("cache_load_s"))


def bench_dynamics(r: dict) -> str:
    """``bench dynamics``: time and error per method and tolerance, both cases side by side."""
    by_key: dict[tuple[str, float], dict[str, dict]] = {}
    for rec in r["records"]:
        by_key.setdefault((rec["method"], rec["atol_mm"]), {})[rec["case"]] = rec
    rows = []
    for (method, atol), cases in by_key.items():
        row: list[Any] = [method, atol]
        for case in ("pickplace", "random"):
            rec = cases.get(case)
            if rec is None:
                row += ["–", "–", "–"]
            else:
                row += [
                    rec["us_per_design"] / 1000.0,
                    rec["reset_time_rel_err"],
                    ratio(rec["speedup_vs_radau"]),
                ]
        rows.append(row)
    header = [
        "method",
        "atol mm",
        "pick-and-place: ms",
        "max rel. error",
        "vs Radau",
        f"{r['random_designs']} random: ms per design",
        "max rel. error",
        "vs Radau",
    ]
    base = r["radau_baseline_us_per_design"]
    mism = sum(rec["class_mismatches"] + rec["state_mismatches"] for rec in r["records"])
    check = r["reference_check_random"]
    text = table(header, rows)
    text += (
        f"\nRadau baseline: {fmt(base['pickplace'] / 1000.0)} ms on pick-and-place, "
        f"{fmt(base['random'] / 1000.0)} ms per random design. Unit-class or final-state "
        f"mismatches over all rows: {mism}. Reference check: our tight Rodas4 against tight Radau "
        f"on {check['designs']} random designs, largest relative reset-time error "
        f"{fmt(check['reset_time_rel_err'])}.\n"
    )
    return text + compile_line(r.get("compile_s"), r.get("cache_load_s"))


def bench_sweep(r: dict) -> str:
    """``bench sweep``: the paper job on both engines, the overnight outputs, memory."""
    job = r["paper_job"]
    dask = r["engines"]["dask"]
    one = job["one_at_a_time"]
    night = r["overnight_outputs"]
    rows = [
        [
            f"paper job ({fmt(job['designs'])} designs), local engine, with Parquet",
            f"{fmt(job['wall_s'])} s",
            job["designs_per_s"],
            f"1 (goal <= {fmt(job['goal_wall_s'])} s: "
            f"{goal_cell(job['wall_s'] <= job['goal_wall_s'])})",
        ],
        [
            "same designs one at a time through the API, projected",
            f"{fmt(one['projected_job_s'])} s",
            "–",
            ratio(one["projected_job_s"] / job["wall_s"]) + " slower",
        ],
        [
            "the paper's model (quoted time per design, not run)",
            f"{fmt(job['paper_model_s'])} s",
            "–",
            ratio(job["speedup_vs_paper_model"]) + " slower",
        ],
        [
            f"paper job, Dask LocalCluster ({dask['workers']} workers)",
            f"{fmt(dask['wall_s'])} s (chunks {fmt(dask['chunks_s'])} s)",
            dask["designs_per_s"],
            f"{ratio(dask['overhead_ratio_vs_local'])} local in all, "
            f"{ratio(dask['chunks_ratio_vs_local'])} in the chunks",
        ],
        [
            f"overnight outputs ({fmt(night['designs'])}-design sample)",
            f"{fmt(night['wall_s'])} s",
            night["designs_per_s"],
            f"whole job ({fmt(night['overnight_designs'])} designs) projected "
            f"{fmt(night['projected_overnight_h'])} h",
        ],
    ]
    text = table(["", "wall", "designs/s", "ratio"], rows)
    timings = dask["timings_s"]
    text += (
        f"\nDask overhead: cluster start {fmt(timings['cluster_start_s'])} s, worker warm-up "
        f"{fmt(timings['worker_warmup_s'])} s, close {fmt(timings['cluster_close_s'])} s; "
        f"largest difference of its rows from the local engine's "
        f"{fmt(dask['max_abs_difference_vs_local'])}, "
        f"of the one-at-a-time API's {fmt(one['max_abs_difference'])}.\n"
    )
    mem = [
        ["paper job, local engine", job["designs"], "–", job["peak_rss_mb"]],
        ["paper job, Dask (all processes)", dask["designs"], "–", dask["peak_rss_mb"]],
    ]
    for run in r.get("rss", {}).values():
        mem.append(
            [f"`dpfexplore sweep`: {run['job']}", run["designs"], run["wall_s"], run["peak_rss_mb"]]
        )
    text += "\n" + table(["run", "designs", "wall s", "peak RSS MB"], mem)
    return text + compile_line(r.get("compile_cold_s"), r.get("cache_load_s"))


def bench_sensitivities(r: dict) -> str:
    """``bench sensitivities``: kernel costs and errors per N, then the API against its kernels."""
    rows = [
        [
            n["n_units"],
            n["parameters"],
            n["solve_us"],
            n["sensitivities_us"],
            ratio(n["ratio_median"]),
            ratio(n["ratio_p90"]),
            n["fd_api_us"],
            n["fd_kernel_floor_us"],
            n["ours_rel_err"],
            n["fd_rel_err"],
            n["ours_stiffness_rel_err"],
            n["fd_stiffness_rel_err"],
        ]
        for n in r["by_n_units"]
    ]
    header = [
        "N",
        "parameters",
        "solve µs",
        "sensitivities µs",
        "ratio (median)",
        "p90",
        "FD through the API µs",
        "FD kernel floor µs",
        "ours rel. error",
        "FD rel. error",
        "ours stiffness error",
        "FD stiffness error",
    ]
    text = table(header, rows)
    api = [
        [
            f"`find_state`, {c['design']} (N = {c['n_units']}, `{c['state']}`)",
            c["find_state_us"],
            c["kernel_us"],
            ratio(c["ratio"]),
            c["find_state_sensitivities_us"],
            c["kernel_sensitivities_us"],
            ratio(c["ratio_sensitivities"]),
        ]
        for c in r["api"]["find_state"]
    ]
    api += [
        [
            f"`solve_batch`, {c['batch']} design(s), per design",
            c["solve_batch_us_per_design"],
            c["kernel_us_per_design"],
            ratio(c["ratio"]),
            c["solve_batch_sensitivities_us_per_design"],
            c["kernel_sensitivities_us_per_design"],
            ratio(c["ratio_sensitivities"]),
        ]
        for c in r["api"]["solve_batch"]
    ]
    text += "\nThe API against the kernels it runs:\n\n" + table(
        ["call", "API µs", "kernel µs", "ratio", "with sensitivities µs", "kernel µs", "ratio"], api
    )
    return text + compile_line(r.get("compile_s"), r.get("cache_load_s"))


def bench_lookup(r: dict) -> str:
    """``bench lookup``: index build, queries against a scan, refinement."""
    build, query, ref = r["build"], r["query"], r["refinement"]
    exact, cd = ref["exact"], ref["central_differences"]
    ds = r["dataset"]
    rows = [
        [
            "index build per million rows (SHA-256 of every chunk included)",
            f"{fmt(build['build_s_per_million_rows'])} s (unverified "
            f"{fmt(build['build_unverified_s'])} s; trees alone {fmt(build['trees_s'])} s; "
            f"reload from its {fmt(build['file_mb'])} MB file {fmt(build['load_s'])} s)",
            "–",
            "–",
            f"<= {fmt(build['goal_build_s_per_million_rows'])} s: "
            f"{goal_cell(build['build_goal_met'])}",
        ]
    ]
    for name, case in query["cases"].items():
        rows.append(
            [
                f"query, k = {query['k']}, {name} ({query['targets']} targets)",
                f"{fmt(case['ours_ms'])} ms (p90 {fmt(case['ours_p90_ms'])})",
                f"brute-force scan {fmt(case['scan_ms'])} ms",
                ratio(case["speedup"]),
                f"<= {fmt(query['goal_ms'])} ms: {goal_cell(query['query_goal_met'])}"
                if name == "all N"
                else "",
            ]
        )
    rows.append(
        [
            f"refinement to 1e-6 mm, {ref['held_out_designs']} held-out tips",
            f"{pct(exact['met_first_candidate'])} met by the first candidate, "
            f"{fmt(exact['ms_per_candidate'])} ms per candidate "
            f"(p90 {fmt(exact['ms_per_candidate_p90'])}), "
            f"worst {fmt(exact['worst_met_error_mm'])} mm",
            f"central differences ({cd['targets']} targets): {pct(cd['met_first_candidate'])}, "
            f"{fmt(cd['ms_per_candidate'])} ms (p90 {fmt(cd['ms_per_candidate_p90'])})",
            ratio(ref["speedup_vs_central"]),
            f"<= {fmt(ref['goal_ms_per_candidate'])} ms, >= {pct(ref['goal_share_met'])}: "
            f"{goal_cell(ref['time_goal_met'] and ref['share_goal_met'])}",
        ]
    )
    head = (
        f"Dataset `{ds['path']}`: {fmt(ds['rows'])} rows, {fmt(build['rows_indexed'])} of them "
        f"`ok` and indexed.\n\n"
    )
    same = all(c["same_rows_as_scan"] for c in query["cases"].values())
    tail = f"\nQueries return the same rows as the scan: {fmt(same)}.\n"
    return head + table(["", "ours", "baseline", "ratio", "goal"], rows) + tail


def bench_snap(r: dict) -> str:
    """``bench snap``: continuation cost per N and the slow-ramp lags."""
    rows = [
        [
            n["n_units"],
            n["designs"],
            n["median_ms"],
            n["p90_ms"],
            n["median_ms_with_release"],
            n["batch_mean_ms_with_release"],
            n["mean_snaps"],
            n["failed"],
        ]
        for n in r["by_n_units"]
    ]
    g = r["gripper"]
    rows.append(
        [
            "gripper",
            g["designs"],
            g["median_ms"],
            "–",
            g["median_ms_with_release"],
            "–",
            g["mean_snaps"],
            g["failed"],
        ]
    )
    text = f"Rising ramp to {fmt(r['P_max'])} MPa.\n\n" + table(
        [
            "N",
            "designs",
            "median ms",
            "p90 ms",
            "+ release ms",
            "batch ms",
            "snaps per design",
            "failed",
        ],
        rows,
    )
    lag_rows = []
    for label, s in (("random designs", r["slow_ramp"]), ("gripper", r["slow_ramp_gripper"])):
        for dur, mx, med, mism in zip(
            s["durations_s"],
            s["max_lag_MPa"],
            s["median_lag_MPa"],
            s["final_state_mismatches"],
            strict=True,
        ):
            lag_rows.append([f"{label} ({s['designs']})", dur, 1000.0 * mx, 1000.0 * med, mism])
    text += (
        "\nSlow-ramp simulations (Rodas4) against the continuation's snap pressures:\n\n"
        + table(
            [
                "designs",
                "ramp duration s",
                "largest lag kPa",
                "median lag kPa",
                "final-state mismatches",
            ],
            lag_rows,
        )
    )
    lo, hi = r["slow_ramp"]["lag_exponent_range"]
    text += (
        f"\nThe lag shrinks like `rate^p` with median p = "
        f"{fmt(r['slow_ramp']['lag_exponent_median'])} "
        f"({fmt(lo)}–{fmt(hi)}; a slow passage through a saddle-node lags by `O(rate^(2/3))`). One "
        f"slowest-ramp simulation of the gripper costs {fmt(g['slow_ramp_sim_ms'])} ms, "
        f"{ratio(g['speedup_vs_slow_ramp'])} the whole continuation.\n"
    )
    return text + compile_line(r.get("compile_s"), r.get("cached_first_call_s"))


def bench_reset_model(r: dict) -> str:
    """``bench reset-model``: the fast model against the full one, with its goals."""
    goals = r["goals_met"]
    pp = r["pickplace"]
    rows = [
        [
            "time per design",
            f"{fmt(r['us_per_design'])} µs (full model {fmt(r['full_model_us_per_design'])} µs: "
            f"{ratio(r['speedup'])})",
            goal_cell(goals["us_per_design"]),
        ],
        [
            f"relative error, median / p95 / max over {fmt(r['metastable_units'])} "
            "metastable units",
            f"{pct(r['median_rel_err'])} / {pct(r['p95_rel_err'])} / {pct(r['max_rel_err'])}",
            f"{goal_cell(goals['median_rel_err'])} / {goal_cell(goals['p95_rel_err'])} / "
            f"{goal_cell(goals['max_rel_err'])}",
        ],
        [
            "pick-and-place finger, largest relative error",
            f"{pct(pp['max_rel_err'])}, fallback: {fmt(pp['fallback'])}",
            goal_cell(goals["pickplace_within_2pct"]),
        ],
        [
            f"unit class agreement ({fmt(r['units'])} units)",
            pct(r["class_agreement"]),
            goal_cell(goals["class_agreement"]),
        ],
        [
            f"90 % interval coverage ({fmt(r['coverage_units'])} units)",
            pct(r["coverage_90"]),
            goal_cell(goals["coverage_90"]),
        ],
        ["fallback rate", pct(r["fallback_rate"]), "reported"],
    ]
    text = f"{fmt(r['designs'])} held-out designs (seed {r['seed']}).\n\n"
    text += table(["measure", "measured", "goal"], rows)
    reasons = [[k, v] for k, v in r["fallback_reasons"].items()]
    text += "\nFallbacks by reason:\n\n" + table(["reason", "designs"], reasons)
    return text


def bench_surrogate(r: dict) -> str:
    """``bench surrogate``: speed and held-out error per kind, classifiers, goals."""
    s = r["surrogates"]
    rows = [
        [
            m["model"],
            m["us_batched"],
            m["us_single"],
            m.get("tip_median"),
            m.get("tip_p95"),
            m.get("tip_max"),
            m["fit_s"],
        ]
        for m in s["speed"]
    ]
    split = s["split"]
    text = (
        f"{fmt(split['train_designs'])} training designs, {fmt(split['test_designs'])} held out "
        f"({fmt(split['test_rows_ok'])} held-out rows whose state exists); sweep "
        f"{fmt(r['dataset']['sweep_s'])} s, fit and report {fmt(r['fit_and_report_s'])} s.\n\n"
    )
    text += table(
        ["model", "batched µs", "single µs", "tip error median mm", "p95 mm", "max mm", "fit s"],
        rows,
    )
    used = s["classifier"]["kind"]
    cls = []
    for c in s["classifiers"]:
        worst_n, worst = min(c["accuracy_per_n"].items(), key=lambda kv: kv[1])
        label = f"{c['kind']} (used)" if c["kind"] == used else c["kind"]
        cls.append(
            [
                label,
                pct(c["accuracy"], 4),
                f"{pct(worst, 4)} (N = {worst_n})",
                c["missed"],
                c["false_alarms"],
            ]
        )
    text += "\n" + table(
        ["status classifier", "held-out accuracy", "worst N", "missed", "false alarms"], cls
    )
    goals = [
        [name.replace("_", " "), g["goal"], g["value"], goal_cell(g["met"])]
        for name, g in s["goals"].items()
    ]
    text += "\n" + table(["goal", "target", "measured", ""], goals)
    return text + f"\nVerdict recorded with the report: {s['verdict']}\n"


def _target(row: dict) -> str:
    return (
        "(" + ", ".join(fmt(float(v), 3) for v in row["target"]) + ")"
        if row["target"]
        else "all requirements"
    )


def bench_design(r: dict) -> str:
    """``bench design``: position targets and the gripper against TPE and GP-BO."""
    rows, ratios = [], {(tuple(q["target"]), q["material"]): q for q in r["summary"]["ratios"]}
    for row in r["rows"]:
        m = row["methods"]
        q = ratios.get((tuple(row["target"]), row["material"]), {})
        seeded = (
            f"{fmt(row['ours_seeded_evals'])} / {fmt(row['ours_seeded_wall_s'])}"
            if row.get("ours_seeded_evals") is not None
            else "–"
        )
        base = "–"
        if row.get("baseline_evals") is not None:
            base = (
                f"{fmt(row['baseline_evals'])} / {fmt(row['baseline_wall_s'])} "
                f"({row['best_baseline']})"
            )
        elif row.get("baseline_budget_evals") is not None:
            base = f"none in {fmt(row['baseline_budget_evals'])}"
        rows.append(
            [
                f"{row['scene']} {_target(row)}",
                row["material"],
                row["paper_objective"],
                f"{fmt(row['ours_evals'])} / {fmt(row['ours_wall_s'])}",
                seeded,
                base,
                f"{fmt(m.get('tpe', {}).get('objective'))} / "
                f"{fmt(m.get('gp', {}).get('objective'))}",
                ratio(q.get("seeded_evals_ratio"), not q.get("baseline_reached_paper", True)),
                ratio(q.get("seeded_wall_ratio"), not q.get("baseline_reached_paper", True)),
                ratio(q.get("wall_ratio"), not q.get("baseline_reached_paper", True)),
            ]
        )
    header = [
        "scene, target",
        "material",
        "paper's objective",
        "ours, LHS: evals / s to the paper's objective",
        "ours, seeded: evals / s",
        "best baseline: evals / s",
        "baselines' best objective (TPE / GP)",
        "evals ratio, seeded",
        "wall ratio, seeded",
        "wall ratio, LHS",
    ]
    summ = r["summary"]
    text = table(header, rows)
    text += (
        f"\nPosition targets met to 1e-6: {summ['position_met_1e-6']} of "
        f"{summ['position_targets']}; "
        f"slowest target {fmt(summ['position_max_wall_s'])} s. Seed datasets opened in "
        + ", ".join(f"{fmt(v['open_s'])} s (`{k}`)" for k, v in r["seed_datasets"].items())
        + ".\n"
    )
    return text


def bench_design_timing(r: dict) -> str:
    """``bench design --skip-position --skip-gripper``: timing scenes against TPE."""
    rows = []
    for row in r["rows"]:
        tpe = row["methods"]["tpe"]
        tpe_cell = (
            fmt(tpe["evals"]) if tpe.get("evals_to_goal") is None else fmt(tpe["evals_to_goal"])
        )
        rows.append(
            [
                row["scene"],
                _target(row),
                row["ours_evals"],
                row["ours_wall_s"],
                tpe_cell,
                row["baseline_wall_s"],
                ratio(row["wall_ratio_to_goal"], row["wall_ratio_is_lower_bound"]),
                ratio(
                    row.get("wall_ratio_to_tight"),
                    row.get("wall_ratio_to_tight_is_lower_bound", False),
                ),
            ]
        )
    header = [
        "scene",
        "target s",
        "ours: evaluations",
        "ours: s to the goal",
        "TPE: evaluations",
        "TPE: s to the goal",
        "wall ratio",
        "to the tight goal",
    ]
    return table(header, rows)


def bench_identify(r: dict) -> str:
    """``bench identify``: fitting and selection time, errors of ours, the baseline, the forms."""
    text = (
        f"{fmt(r['curves'])} curves of {fmt(r['points_per_curve'])} points (noise "
        f"{fmt(r['noise'])}): fit {fmt(r['fit_s'])} s, selection {fmt(r['select_s'])} s, total "
        f"{fmt(r['total_s'])} s (goal <= {fmt(r['goal_s'])} s: "
        f"{goal_cell(r['total_s'] <= r['goal_s'])}); {fmt(r['ours_ms_per_curve'])} ms per curve "
        f"against {fmt(r['baseline_ms_per_curve'])} ms for the baseline "
        f"({ratio(r['ratio_baseline_over_ours'])}); {r['flagged']} fits flagged.\n\n"
    )
    rows = []
    for label, key in (
        ("ours", "ours"),
        ("baseline (SciPy curve_fit)", "baseline"),
        ("selected closed forms", "closed_form"),
    ):
        kb, al = r[f"{key}_k_b_error"], r[f"{key}_alpha_error"]
        rows.append([label, kb["median"], kb["max"], al["median"], al["max"], kb["failures"]])
    text += table(["", "k_b error median", "max", "alpha error median", "max", "failures"], rows)
    terms = ", ".join(
        f"`{k}` {n} terms ({r['heldout_winner'].get(k, '?')} won held-out)"
        for k, n in r["terms"].items()
    )
    text += f"\nSelected closed forms: {terms}.\n"
    c = r.get("constants_tables")
    if c:
        text += (
            f"\nA set's constants in the kernels, {fmt(c['domes'])} domes (median of "
            f"{c['repeats']}): {fmt(c['set_ns_per_dome'])} ns per dome for the packaged paper set "
            f"against {fmt(c['paper_ns_per_dome'])} ns for the paper's forms compiled as plain "
            f"arithmetic ({fmt(c['ratio_set_over_paper'])}x; `k_b` apart by "
            f"{fmt(c['max_rel_difference_k_b'])}, `alpha` by "
            f"{fmt(c['max_rel_difference_alpha'])}). The kernel tables of "
            f"{fmt(c['table_build_designs'])} designs of 6 units: "
            f"{fmt(1e3 * c['tables_set_median_s'])} ms with the set against "
            f"{fmt(1e3 * c['tables_paper_median_s'])} ms for the same build with the compiled "
            f"paper forms ({fmt(c['ratio_tables_set_over_paper'])}x).\n"
        )
    return text


def bench_unitcell(r: dict) -> str:
    """``bench unitcell``: time per curve against the mesh error, the grid, the solid."""
    rows = [
        [
            x["elements"],
            x["median_s"],
            x["max_s"],
            x["median_steps"],
            x["max_energy_error"],
            x["max_fold_error"],
            x["max_tip_dis_error"],
        ]
        for x in r["rows"]
    ]
    text = table(
        ["elements", "median s", "max s", "steps", "energy error", "fold error", "tip_dis error"],
        rows,
    )
    at_128 = next((x for x in r["rows"] if x["elements"] == 128), None)
    if at_128 is not None:
        met = at_128["median_s"] <= r["goal_s"]
        text += (
            f"\nGoal: one curve <= {fmt(r['goal_s'])} s at 128 elements: {goal_cell(met)} "
            f"(median {fmt(at_128['median_s'])} s, slowest {fmt(at_128['max_s'])} s).\n"
        )
    grid = r.get("grid_sweep")
    if grid:
        text += (
            f"\nGrid: {fmt(grid['curves'])} curves ({grid['grid'][0]} `H` x {grid['grid'][1]} `t`, "
            f"{grid['elements']} elements) by `dpfexplore unitcell sweep` on {grid['workers']} "
            f"workers, Parquet included: {fmt(grid['wall_s'])} s wall "
            f"({fmt(grid['per_curve_s'])} s per curve); goal <= {fmt(grid['goal_s'])} s: "
            f"{goal_cell(grid['wall_s'] <= grid['goal_s'])}. Statuses: {grid['statuses']}.\n"
        )
    for s in r.get("solid_side_by_side", []):
        text += (
            f"\nscikit-fem solid, `H` = {fmt(s['H'])}, `t` = {fmt(s['t'])}: "
            f"{fmt(s['solid_cpu_s'])} s CPU ({fmt(s['solid_dofs'])} unknowns) against "
            f"{fmt(s['shell_s'])} s for the shell; energies apart by at most "
            f"{pct(s['max_energy_difference'])} over 0.25 H to the first fold.\n"
        )
    return text + compile_line(r.get("compile_s"), r.get("cache_load_s"))


def bench_explore(r: dict) -> str:
    """``bench explore``: load, first render, zoom and click on a real dataset, the goals."""
    data, goals, met = r["dataset"], r["goals"], r["goals_met"]
    rows = [
        [
            "first render, warm (ms)",
            r["first_render_warm_ms"],
            goals["first_render_warm_ms"],
            goal_cell(met["first_render_warm"]),
        ],
        ["first render, cold (ms)", r["first_render_cold_ms"], None, ""],
        [
            "zoom re-render, median / p90 (ms)",
            f"{fmt(r['zoom']['median_ms'])} / {fmt(r['zoom']['p90_ms'])}",
            goals["zoom_median_ms"],
            goal_cell(met["zoom"]),
        ],
        [
            "click to verified designs, median / p90 (ms)",
            f"{fmt(r['click']['median_ms'])} / {fmt(r['click']['p90_ms'])}",
            goals["click_median_ms"],
            goal_cell(met["click"]),
        ],
    ]
    text = table(["measure", "measured", "goal", "met"], rows)
    rss = r["server_rss_mb"]
    hosts = ", ".join(sorted({h.split(":")[0] for h in r["request_hosts"]}))
    return text + (
        f"\nDataset `{data['path']}`: {fmt(data['rows'])} rows of {fmt(data['designs'])} designs, "
        f"loaded in {fmt(r['load_s'])} s (index {r['index_action']} in {fmt(r['index_s'])} s). "
        f"Server memory {fmt(rss['loaded'])} MB loaded, {fmt(rss['after_browsing'])} MB after "
        f"browsing; every request to {hosts} "
        f"(offline: {goal_cell(met['offline'])}); {len(r['console_errors'])} console errors. "
        f"Load average during the run: {', '.join(fmt(x) for x in r['load'])}.\n"
    )


def bench_grasp(r: dict) -> str:
    """``bench grasp``: one grasp, a sort of 10^4 objects, the sorting map; the tolerance error."""
    goals, one, srt, grid = r["goals"], r["one_grasp"], r["sort"], r["map"]
    rows = [
        [
            "one grasp (ms)",
            f"{fmt(one['grasp_ms'])} ({fmt(one['grasp_with_payload_ms'])} with its payload)",
            goals["grasp_ms"],
            goal_cell(one["grasp_with_payload_ms"] <= goals["grasp_ms"]),
        ],
        [
            f"sort {fmt(srt['objects'])} objects on {srt['threads']} threads (s)",
            f"{fmt(srt['seconds'])} ({srt['failed']} unconverged, reported as failures)",
            goals["sort_1e4_s"],
            goal_cell(srt["scaled_to_1e4_s"] <= goals["sort_1e4_s"]),
        ],
        [
            f"sorting map {grid['points'][0]} x {grid['points'][1]} (s)",
            grid["seconds"],
            goals["map_100_s"],
            goal_cell(grid["seconds"] <= goals["map_100_s"]),
        ],
    ]
    text = table(["measure", "measured", "goal", "met"], rows)
    tol = r["tolerance_error"]
    for label, key in (("frictionless", "mu_0"), ("μ = 0.5", "mu_0.5")):
        e = tol[key]
        text += (
            f"\nError at the penetration tolerance {fmt(tol['tol_mm'])} mm against "
            f"{fmt(tol['reference_tol_mm'])} mm, {label}, {e['grasps_in_contact']} grasps in "
            f"contact: grip force {fmt(e['grip_max_abs_err_N'])} N ({pct(e['grip_max_rel_err'])}), "
            f"payload {fmt(e['payload_max_abs_err_N'])} N ({pct(e['payload_max_rel_err'])}).\n"
        )
    return text + compile_line(r.get("compile_s"), r.get("cache_load_s"))


#: Placeholder name -> (record file, renderer).
BENCHMARKS: dict[str, tuple[str, Callable[[dict], str]]] = {
    "statics": ("bench-statics.json", bench_statics),
    "dynamics": ("bench-dynamics.json", bench_dynamics),
    "sweep": ("bench-sweep.json", bench_sweep),
    "sensitivities": ("bench-sensitivities.json", bench_sensitivities),
    "lookup": ("bench-lookup.json", bench_lookup),
    "snap": ("bench-snap.json", bench_snap),
    "reset-model": ("bench-reset-model.json", bench_reset_model),
    "surrogate": ("bench-surrogate.json", bench_surrogate),
    "design": ("bench-design.json", bench_design),
    "design-timing": ("bench-design-timing.json", bench_design_timing),
    "identify": ("bench-identify.json", bench_identify),
    "unitcell": ("bench-unitcell.json", bench_unitcell),
    "explore": ("bench-explore.json", bench_explore),
    "grasp": ("bench-grasp.json", bench_grasp),
}

PLACEHOLDER = re.compile(r"\{\{\s*bench\s+([\w-]+)\s*\}\}")


def render_benchmarks(template: str, reports: Path) -> str:
    """The benchmarks page: ``template`` with every ``{{ bench NAME }}`` filled from ``reports``."""

    def fill(match: re.Match) -> str:
        name = match.group(1)
        if name not in BENCHMARKS:
            raise ExtensionError(f"benchmarks template: unknown benchmark {name!r}")
        filename, render = BENCHMARKS[name]
        path = reports / filename
        if not path.exists():
            return (
                f"*No record: `results/reports/{filename}` is missing "
                "(run `dpfexplore bench ... --save`).*\n"
            )
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            return machine_line(record, filename) + "\n" + render(record)
        except (KeyError, TypeError, ValueError) as exc:
            raise ExtensionError(f"results/reports/{filename}: cannot render it ({exc!r})") from exc

    return PLACEHOLDER.sub(fill, template)


# --------------------------------------------------------------------------- gallery


def _docstring(script: Path) -> tuple[str, str]:
    """Title (first line) and caption (the rest) of a script's module docstring."""
    import ast

    doc = ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or script.stem
    title, _, body = doc.partition("\n")
    return title.strip().rstrip("."), body.strip()


def run_examples(examples: Path, out_dir: Path) -> list[tuple[Path, Path, float]]:
    """Run every example script (two at a time) with its PNG path; (script, image, seconds)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    scripts = sorted(examples.glob("*.py"))
    env = dict(os.environ, MPLBACKEND="Agg")
    results: list[tuple[Path, Path, float]] = []
    pending = list(scripts)
    running: list[tuple[Path, Path, subprocess.Popen, float]] = []
    while pending or running:
        while pending and len(running) < 2:
            script = pending.pop(0)
            image = out_dir / f"{script.stem}.png"
            image.unlink(missing_ok=True)
            proc = subprocess.Popen(
                [sys.executable, str(script), str(image)],
                cwd=str(examples.parent.parent),
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
            running.append((script, image, proc, time.perf_counter()))
        script, image, proc, start = running.pop(0)
        try:
            output, _ = proc.communicate(timeout=EXAMPLE_TIMEOUT_S)
        except subprocess.TimeoutExpired as exc:
            proc.kill()
            raise ExtensionError(
                f"gallery: {script.name} took more than {EXAMPLE_TIMEOUT_S} s"
            ) from exc
        seconds = time.perf_counter() - start
        if proc.returncode != 0 or not image.exists():
            raise ExtensionError(
                f"gallery: {script.name} failed (exit {proc.returncode}, image written: "
                f"{image.exists()}):\n{output}"
            )
        results.append((script, image, seconds))
    return sorted(results)


def render_gallery(runs: Sequence[tuple[Path, Path, float]], docs: Path) -> str:
    """The gallery page: per script its title, caption, figure and source."""
    parts = [
        "# Gallery\n",
        "Each figure below was drawn while these pages were built, by the script shown under it "
        "(`docs/examples/`), with the public API and the code of this checkout. Run one yourself "
        "with `python docs/examples/NAME.py out.png`.\n",
    ]
    for script, image, seconds in runs:
        title, caption = _docstring(script)
        rel_image = image.relative_to(docs / "_generated").as_posix()
        rel_script = os.path.relpath(script, docs / "_generated")
        parts.append(f"## {title}\n")
        if caption:
            parts.append(caption + "\n")
        parts.append(f"```{{image}} {rel_image}\n:alt: {title}\n:width: 100%\n```\n")
        parts.append(f"`docs/examples/{script.name}` (ran in {seconds:.1f} s during this build):\n")
        parts.append(f"```{{literalinclude}} {rel_script}\n:language: python\n```\n")
    return "\n".join(parts)


# --------------------------------------------------------------------------- tutorial


def render_notebook(notebook: Path, out_dir: Path) -> str:
    """A notebook as MyST Markdown, with the outputs of its execution.

    Markdown cells as they are, code cells as code blocks, each followed by its text outputs and
    its figures (PNG files written to ``out_dir/tutorial/``); the executed copy comes from
    :func:`notebook_outputs.executed_notebook` (run once, shared with ``tests/test_tutorial.py``).
    """
    import base64

    from notebook_outputs import executed_notebook

    nb, _ = executed_notebook(notebook, out_dir)
    images = out_dir / notebook.stem
    images.mkdir(parents=True, exist_ok=True)
    parts = []
    for index, cell in enumerate(nb.get("cells", [])):
        source = "".join(cell.get("source", ""))
        if cell.get("cell_type") == "markdown":
            parts.append(source.strip() + "\n")
        elif cell.get("cell_type") == "code" and source.strip():
            parts.append("```python\n" + source.rstrip() + "\n```\n")
            for number, out in enumerate(cell.get("outputs", [])):
                data = out.get("data", {})
                if "image/png" in data:
                    name = f"cell{index}-{number}.png"
                    png = base64.b64decode("".join(data["image/png"]))
                    if not (images / name).is_file() or (images / name).read_bytes() != png:
                        (images / name).write_bytes(png)
                    parts.append(f"![output of the cell above]({notebook.stem}/{name})\n")
                    continue
                text = out.get("text") or data.get("text/plain")
                if text:
                    parts.append("```text\n" + "".join(text).rstrip() + "\n```\n")
    note = (
        "\n```{note}\nThis page is `docs/tutorial.ipynb`, executed when the docs were built "
        "(once: `tests/test_tutorial.py` shares the run), with its outputs. Run it yourself "
        "with Jupyter, or download it: {download}`tutorial.ipynb <../tutorial.ipynb>`.\n```\n"
    )
    first, _, rest = "\n".join(parts).partition("\n")
    return first + "\n" + note + rest


# --------------------------------------------------------------------------- public API


def render_public_api() -> str:
    """Autosummary of ``dpfexplore.__all__``, each name under the module that defines it."""
    import dpfexplore

    names = []
    for name in dpfexplore.__all__:
        obj = getattr(dpfexplore, name)
        module = getattr(obj, "__module__", None) if callable(obj) else None
        if not module or not module.startswith("dpfexplore"):
            module = "dpfexplore" + dpfexplore._EXPORTS[name]
        names.append(f"~{module}.{name}")
    return ".. autosummary::\n   :nosignatures:\n\n" + "".join(f"   {n}\n" for n in names)


# --------------------------------------------------------------------------- Sphinx hooks


def generate(app: Sphinx) -> None:
    """Write every generated page before Sphinx reads the sources."""
    docs = Path(app.srcdir)
    out = docs / "_generated"
    repo = docs.parent
    started = time.perf_counter()
    template = (docs / "_ext" / "templates" / "benchmarks.md").read_text(encoding="utf-8")
    _write_if_changed(
        out / "benchmarks.md", render_benchmarks(template, repo / "results" / "reports")
    )
    _write_if_changed(out / "api_public.rst", render_public_api())
    _write_if_changed(out / "tutorial.md", render_notebook(docs / "tutorial.ipynb", out))
    runs = run_examples(docs / "examples", out / "gallery")
    _write_if_changed(out / "gallery.md", render_gallery(runs, docs))
    LOG.info(
        "generated pages written to %s in %.1f s (gallery: %s)",
        out,
        time.perf_counter() - started,
        ", ".join(f"{s.stem} {t:.1f} s" for s, _, t in runs),
    )


def setup(app: Sphinx) -> dict[str, Any]:
    """Register the generator."""
    app.connect("builder-inited", generate)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
