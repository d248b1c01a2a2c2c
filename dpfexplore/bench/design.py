"""``dpfexplore bench design``: our inverse-design optimiser against black-box optimisers.

All on the same exact evaluator (:class:`dpfexplore.inverse.evaluation.Evaluator`, counting every
design solved, in the same box of design variables, so the constraints are exact for every
method):

* ours: :func:`dpfexplore.inverse.optimiser.solve_position_target` (Latin hypercube for every N,
  gradient refinement) and :func:`dpfexplore.inverse.gripper_design.solve_gripper`;
* TPE: Optuna's ``TPESampler``, with N as a categorical parameter and the box variables of that
  N conditioned on it (define-by-run);
* GP-BO: Gaussian-process Bayesian optimisation (the paper's method; the
  ``bayesian-optimization`` package, UCB acquisition), one optimiser per N as the paper ran it,
  taking turns so that no N is favoured by order.

The paper's ten position targets (five targets, Cheetah 95A and NinjaFlex 85A scenes) and the
gripper: for each method the exact evaluations and wall time to reach 0.5 mm², 1e-6 mm² and the
paper's objective, the best objective at the same number of evaluations and at the same wall
time as ours, and the best objective within the baseline's budget. A black-box method gets
:data:`PENALTY` for a design whose targeted state does not exist (it has no tip in that state).
Baselines need the ``baselines`` extra (``pip install -e ".[baselines]"``).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

from ._common import REPORTS, emit, machine_info

JOBS = Path(__file__).resolve().parents[2] / "jobs"
#: The paper's best position objectives (mm², MODEL.md §9), per material.
PAPER_OBJECTIVES = {
    "cheetah-95a": (0.775, 0.056, 0.55, 0.22, 0.32),
    "ninjaflex-85a": (0.2, 0.2, 2.9, 0.8, 0.4),
}
SCENES = {"cheetah-95a": "design-position-cheetah.toml",
          "ninjaflex-85a": "design-position-ninjaflex.toml"}  # fmt: skip
#: Objective a black-box method receives for a design whose targeted state does not exist, mm².
PENALTY = 1.0e3
THRESHOLDS = (0.5, 1e-6)


def register(subparsers) -> None:
    """Add ``bench design``."""
    parser = subparsers.add_parser(
        "design",
        help="inverse design: our optimiser vs Optuna TPE and GP Bayesian optimisation",
        description=__doc__.split("\n\n")[0],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument("--save", action="store_true",
                        help=f"also write the record to {REPORTS}/bench-design.json")
    parser.add_argument("--targets", default="1,2,3,4,5", help="targets (1-based) to run")
    parser.add_argument("--materials", default="cheetah-95a,ninjaflex-85a")
    parser.add_argument("--n-units", default=None,
                        help="override the scenes' N range, e.g. 2,3 (default: the scenes')")
    parser.add_argument("--tpe-budget", type=int, default=1500, help="TPE evaluations per target")
    parser.add_argument("--gp-budget", type=int, default=350,
                        help="GP-BO evaluations per target (shared by its N)")
    parser.add_argument("--skip-gripper", action="store_true", help="position targets only")
    parser.add_argument("--gripper-budget", type=int, default=600,
                        help="baseline evaluations on the gripper's apertures")
    parser.add_argument("--seed", type=int, default=0)
    parser.set_defaults(handler=run)


# ----------------------------------------------------------------------------- baselines


def _position_objective(problems, target_point):
    """Black-box objective of (N, z) on the exact evaluator (one design per call)."""

    def f(n: int, z: np.ndarray) -> float:
        ev = problems[n].evaluate(z[None, :], purpose="baseline")
        value = float(ev.objective[0])
        return value if math.isfinite(value) else PENALTY

    return f


def run_tpe(problems, f, budget: int, seed: int) -> None:
    """Optuna TPE over N (categorical) and the box variables of that N."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed)
    study = optuna.create_study(sampler=sampler, direction="minimize")

    def objective(trial) -> float:
        n = trial.suggest_categorical("N", sorted(problems))
        z = np.array([trial.suggest_float(f"z{n}_{j}", 0.0, 1.0)
                      for j in range(problems[n].dim)])  # fmt: skip
        return f(n, z)

    study.optimize(objective, n_trials=budget)


def run_gp(problems, f, budget: int, seed: int) -> None:
    """GP-BO per N (bayesian-optimization, UCB), the N taking turns."""
    import warnings

    from bayes_opt import BayesianOptimization

    optimisers = {}
    for n, p in problems.items():
        bounds = {f"z{j:02d}": (0.0, 1.0) for j in range(p.dim)}
        optimisers[n] = BayesianOptimization(f=None, pbounds=bounds, random_state=seed + n,
                                             verbose=0, allow_duplicate_points=True)  # fmt: skip
    ns = sorted(problems)
    for i in range(budget):
        n = ns[i % len(ns)]
        opt = optimisers[n]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            params = opt.suggest()
        z = np.array([params[f"z{j:02d}"] for j in range(problems[n].dim)])
        opt.register(params=params, target=-f(n, z))


# ----------------------------------------------------------------------------- runs


def _summary(evaluator, paper: float, ours_evals: float, ours_wall: float) -> dict:
    out = {"evals": evaluator.counts["designs"], "wall_s": evaluator.wall_s,
           "objective": evaluator.best_at()}  # fmt: skip
    for name, threshold in (("0.5", 0.5), ("1e-6", 1e-6), ("paper", paper)):
        count, seconds = evaluator.reached(threshold)
        out[f"evals_to_{name}"], out[f"wall_s_to_{name}"] = count, seconds
    out["objective_at_ours_evals"] = evaluator.best_at(evaluations=ours_evals)
    out["objective_at_ours_wall"] = evaluator.best_at(seconds=ours_wall)
    return out


def bench_position(spec, index: int, material: str, args) -> dict:
    """One position target: ours, TPE and GP-BO."""
    from ..inverse.evaluation import Evaluator
    from ..inverse.optimiser import position_problems, solve_position_target

    paper = PAPER_OBJECTIVES[material][index]
    ours = Evaluator(max(spec.n_units))
    solve_position_target(spec, index, ours)
    mine = _summary(ours, paper, np.inf, np.inf)
    methods = {"ours": mine}
    for name, runner, budget in (("tpe", run_tpe, args.tpe_budget),
                                 ("gp", run_gp, args.gp_budget)):  # fmt: skip
        try:
            evaluator = Evaluator(max(spec.n_units))
            problems = {p.n_units: p for p in position_problems(spec, index, evaluator)}
            runner(problems, _position_objective(problems, spec.targets[index].point), budget,
                   args.seed)  # fmt: skip
            methods[name] = _summary(evaluator, paper, mine["evals"], mine["wall_s"])
        except ImportError as exc:
            methods[name] = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
    return _row("position", spec.targets[index].point, material, paper, methods)


def _row(scene: str, target, material: str, paper: float | None, methods: dict) -> dict:
    ours = methods["ours"]
    key = "paper" if paper is not None else "1e-6"
    baselines = {k: v for k, v in methods.items() if k != "ours" and "error" not in v}

    def rank(item):
        v = item[1]
        reached = v.get(f"evals_to_{key}")
        return (reached is None, reached if reached is not None else v["objective"])

    best_name, best = min(baselines.items(), key=rank) if baselines else (None, {})
    return {
        "scene": scene, "target": list(target), "material": material, "paper_objective": paper,
        "ours_evals": ours.get(f"evals_to_{key}"), "ours_wall_s": ours.get(f"wall_s_to_{key}"),
        "ours_objective": ours["objective"], "ours_total_evals": ours["evals"],
        "ours_total_wall_s": ours["wall_s"],
        "best_baseline": best_name, "baseline_evals": best.get(f"evals_to_{key}"),
        "baseline_wall_s": best.get(f"wall_s_to_{key}"),
        "baseline_objective": best.get("objective"),
        "baseline_budget_evals": best.get("evals"), "methods": methods,
    }  # fmt: skip


def bench_gripper(args) -> dict:
    """The gripper: ours against the baselines on the apertures' squared error (mm²)."""
    from ..inverse.evaluation import Evaluator
    from ..inverse.gripper_design import gripper_problem, solve_gripper
    from ..inverse.scene_jobs import load_scene

    spec = load_scene(JOBS / "design-gripper.toml")
    ours = Evaluator(5)
    result = solve_gripper(spec, 0, ours)
    mine = _summary(ours, 0.05**2, np.inf, np.inf)
    mine["final_objective"] = float(result.best.objective)
    mine["final_stiffness"] = float(result.best.evaluation.stiffness[0])
    methods = {"ours": mine}
    for name, runner in (("tpe", run_tpe), ("gp", run_gp)):
        try:
            evaluator = Evaluator(5)
            problem = gripper_problem(spec, evaluator)

            def f(n, z, problem=problem):
                ev = problem.evaluate(z[None, :], purpose="baseline")
                value = float(ev.objective[0])
                return value if math.isfinite(value) else PENALTY

            runner({5: problem}, f, args.gripper_budget, args.seed)
            methods[name] = _summary(evaluator, 0.05**2, mine["evals"], mine["wall_s"])
        except ImportError as exc:
            methods[name] = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
    return _row("gripper", spec.gripper.apertures, spec.material, 0.05**2, methods)


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench design``."""
    from ..inverse.scene_jobs import load_scene, parse_scene

    logging.getLogger("bayes_opt").setLevel(logging.WARNING)
    rows = []
    started = time.perf_counter()
    targets = [int(t) - 1 for t in args.targets.split(",") if t]
    for material in [m for m in args.materials.split(",") if m]:
        spec = load_scene(JOBS / SCENES[material])
        if args.n_units:
            document = dict(spec.document)
            document["variables"] = {**document["variables"],
                                     "n_units": [int(n) for n in args.n_units.split(",")]}
            spec = parse_scene(document, default_name=spec.name)
        for index in targets:
            rows.append(bench_position(spec, index, material, args))
            _progress(rows[-1], started)
    if not args.skip_gripper:
        rows.append(bench_gripper(args))
        _progress(rows[-1], started)
    record = {"benchmark": "design", "machine": machine_info(), "rows": rows,
              "wall_s": time.perf_counter() - started, "summary": _goals(rows)}  # fmt: skip
    save = REPORTS / "bench-design.json" if args.save else None
    emit(record, as_json=args.json, text=_text(record), save=save)
    return 0


def _progress(row: dict, started: float) -> None:
    print(f"{time.perf_counter() - started:8.1f} s  {row['scene']} {row['target']} "
          f"{row['material']}: ours {row['ours_objective']:.2e}, {row['best_baseline']} "
          f"{_fmt(row['baseline_objective'], '.2e')}", file=sys.stderr, flush=True)


def _ratio(a, b):
    if a is None or b is None or a <= 0:
        return None
    return b / a


def _goals(rows: list[dict]) -> dict:
    position = [r for r in rows if r["scene"] == "position"]
    out = {"position_targets": len(position),
           "position_met_1e-6": sum(r["ours_objective"] <= 1e-6 for r in position),
           "position_max_wall_s": max((r["ours_total_wall_s"] for r in position), default=None)}
    ratios = []
    for r in position:
        base_evals = r["baseline_evals"]
        if base_evals is None:  # not reached within the budget: a lower bound
            base_evals = r["baseline_budget_evals"]
        ratios.append({"target": r["target"], "material": r["material"],
                       "evals_ratio": _ratio(r["ours_evals"], base_evals),
                       "wall_ratio": _ratio(r["ours_wall_s"], r["baseline_wall_s"]),
                       "baseline_reached_paper": r["baseline_evals"] is not None})  # fmt: skip
    out["ratios"] = ratios
    return out


def _fmt(v, spec=".3g") -> str:
    return "-" if v is None else format(v, spec)


def _text(record: dict) -> str:
    lines = ["bench design: evaluations (designs solved) and wall time to reach the paper's "
             "objective; best objective (mm²) within each budget",
             f"{'scene':9} {'target':>14} {'material':>14} {'paper':>6} | {'ours ev':>7} "
             f"{'ours s':>7} {'ours obj':>9} | {'baseline':>8} {'ev':>6} {'s':>7} {'obj':>9} "
             f"{'budget':>6}"]  # fmt: skip
    for r in record["rows"]:
        t = "(" + ", ".join(f"{v:g}" for v in r["target"]) + ")"
        lines.append(
            f"{r['scene']:9} {t:>14} {r['material']:>14} {_fmt(r['paper_objective']):>6} | "
            f"{_fmt(r['ours_evals'], 'd'):>7} {_fmt(r['ours_wall_s'], '.3f'):>7} "
            f"{_fmt(r['ours_objective'], '.2e'):>9} | {r['best_baseline'] or '-':>8} "
            f"{_fmt(r['baseline_evals'], 'd'):>6} {_fmt(r['baseline_wall_s'], '.2f'):>7} "
            f"{_fmt(r['baseline_objective'], '.2e'):>9} {_fmt(r['baseline_budget_evals'], 'd'):>6}"
        )
    s = record["summary"]
    lines.append(f"position targets met to 1e-6 mm²: {s['position_met_1e-6']}/"
                 f"{s['position_targets']}; slowest target {_fmt(s['position_max_wall_s'])} s")
    lines.append(f"total {record['wall_s']:.1f} s on {record['machine']['cores']} cores "
                 f"({record['machine']['cpu']})")  # fmt: skip
    return "\n".join(lines)
