"""``dpfexplore bench design``: our inverse-design optimiser against black-box optimisers.

All on the same exact evaluator (:class:`dpfexplore.inverse.evaluation.SceneEvaluator`,
counting every design solved, in the same box of design variables, so the constraints are exact
for every method):

* ours: :func:`dpfexplore.inverse.engine.optimiser.solve_position_target` (Latin hypercube for
  every N, gradient refinement with the model's sensitivities) and
  :func:`dpfexplore.inverse.scenes.gripper.solve.solve_gripper`;
* ours, seeded: the same optimiser with its candidates taken from a sweep dataset of the scene's
  constraints (:mod:`dpfexplore.inverse.engine.seeds`, ``jobs/design-seeds-*.toml``, swept here if
  missing); the dataset's own evaluations (a one-off sweep shared by every target and both
  materials) and the time to open it for the process (its tip index and design columns, shared
  by every target) are reported apart, not counted in the rows;
* TPE: Optuna's ``TPESampler``, with N as a categorical parameter and the box variables of that
  N conditioned on it (define-by-run);
* GP-BO: Gaussian-process Bayesian optimisation (the paper's method; the
  ``bayesian-optimization`` package, UCB acquisition), one optimiser per N as the paper ran it,
  taking turns so that no N is favoured by order.

The paper's ten position targets (five targets, Cheetah 95A and NinjaFlex 85A scenes), the
gripper, and the timing scenes (pick-and-place target reset times and walker legs, against TPE at
equal wall time: :mod:`dpfexplore.bench.design.timing`): for each method the exact evaluations
and wall time to reach 0.5 mm², 1e-6 mm² and the paper's objective, the best objective at the
same number of evaluations and at the same wall time as ours, and the best objective within the
baseline's budget. A black-box method gets
:data:`PENALTY` for a design whose targeted state does not exist (it has no tip in that state).
Baselines need the ``baselines`` extra (``pip install -e ".[baselines]"``).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

from .._common import REPORTS, count, emit, int_list, machine_info, name_list

JOBS = Path(__file__).resolve().parents[3] / "jobs"
#: The paper's best position objectives (mm², MODEL.md §9), per material.
PAPER_OBJECTIVES = {
    "cheetah-95a": (0.775, 0.056, 0.55, 0.22, 0.32),
    "ninjaflex-85a": (0.2, 0.2, 2.9, 0.8, 0.4),
}
SCENES = {
    "cheetah-95a": "design-position-cheetah.toml",
    "ninjaflex-85a": "design-position-ninjaflex.toml",
}
#: Objective a black-box method receives for a design whose targeted state does not exist, mm².
PENALTY = 1.0e3


def register(subparsers) -> None:
    """Add ``bench design``."""
    parser = subparsers.add_parser(
        "design",
        help="inverse design: our optimiser vs Optuna TPE and GP Bayesian optimisation",
        description=__doc__.split("\n\n")[0],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save", action="store_true", help=f"also write the record to {REPORTS}/bench-design.json"
    )
    parser.add_argument(
        "--save-as",
        default="bench-design.json",
        metavar="NAME",
        type=_json_name,
        help="file name of --save under the reports folder (e.g. "
        "bench-design-timing.json for a run of the timing scenes only)",
    )
    parser.add_argument(
        "--targets", type=int_list(1, 5), default="1,2,3,4,5", help="targets (1-based) to run"
    )
    parser.add_argument(
        "--materials",
        type=name_list(sorted(SCENES)),
        default="cheetah-95a,ninjaflex-85a",
        help=f"position scenes' materials, comma-separated, of: {', '.join(sorted(SCENES))}",
    )
    parser.add_argument(
        "--n-units",
        default=None,
        help="override the scenes' N range, e.g. 2,3 (default: the scenes')",
    )
    parser.add_argument(
        "--tpe-budget", type=count(1), default=1500, help="TPE evaluations per target"
    )
    parser.add_argument(
        "--gp-budget",
        type=count(1),
        default=350,
        help="GP-BO evaluations per target (shared by its N)",
    )
    parser.add_argument("--skip-gripper", action="store_true", help="position targets only")
    parser.add_argument(
        "--gripper-budget",
        type=count(1),
        default=600,
        help="baseline evaluations on the gripper's apertures",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the optimisers' random starts")
    parser.add_argument(
        "--no-seeded",
        action="store_true",
        help="position targets: skip our optimiser seeded from a sweep dataset "
        "(results/design-seeds-<order>, made by jobs/design-seeds-*.toml "
        "when missing; its sweep time is reported apart)",
    )
    parser.add_argument("--skip-position", action="store_true", help="no position targets")
    parser.add_argument("--skip-pickplace", action="store_true", help="no pick-and-place targets")
    parser.add_argument("--skip-walker", action="store_true", help="no walker legs")
    parser.add_argument(
        "--pickplace-targets", default="0.3,1,2,3", help="pick-and-place target reset times (s)"
    )
    parser.add_argument(
        "--timing-tpe-factor",
        type=float,
        default=10.0,
        help="timing scenes: TPE gets this many times our wall time",
    )
    parser.add_argument(
        "--timing-min-seconds",
        type=float,
        default=5.0,
        help="timing scenes: TPE gets at least this many seconds",
    )
    parser.set_defaults(handler=run)


def _json_name(text: str) -> str:
    name = Path(text).name
    if name != text or not name.endswith(".json"):
        raise argparse.ArgumentTypeError(f"{text!r}: a file name ending in .json")
    return name


# ----------------------------------------------------------------------------- baselines


def _position_objective(problems):
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
        z = np.array([trial.suggest_float(f"z{n}_{j}", 0.0, 1.0) for j in range(problems[n].dim)])
        return f(n, z)

    study.optimize(objective, n_trials=budget)


def run_gp(problems, f, budget: int, seed: int) -> None:
    """GP-BO per N (bayesian-optimization, UCB), the N taking turns."""
    import warnings

    from bayes_opt import BayesianOptimization

    optimisers = {}
    for n, p in problems.items():
        bounds = {f"z{j:02d}": (0.0, 1.0) for j in range(p.dim)}
        optimisers[n] = BayesianOptimization(
            f=None, pbounds=bounds, random_state=seed + n, verbose=0, allow_duplicate_points=True
        )
    ns = sorted(problems)
    for i in range(budget):
        n = ns[i % len(ns)]
        opt = optimisers[n]
        # bayesian-optimization prints notices (duplicate points) on stdout, whatever its
        # verbosity: they go to stderr, so that `--json` leaves one JSON document on stdout
        with warnings.catch_warnings(), contextlib.redirect_stdout(sys.stderr):
            warnings.simplefilter("ignore")
            params = opt.suggest()
            z = np.array([params[f"z{j:02d}"] for j in range(problems[n].dim)])
            opt.register(params=params, target=-f(n, z))


# ----------------------------------------------------------------------------- runs


def _summary(evaluator, paper: float, ours_evals: float, ours_wall: float) -> dict:
    out = {
        "evals": evaluator.counts["designs"],
        "wall_s": evaluator.wall_s,
        "objective": evaluator.best_at(),
    }
    for name, threshold in (("0.5", 0.5), ("1e-6", 1e-6), ("paper", paper)):
        count, seconds = evaluator.reached(threshold)
        out[f"evals_to_{name}"], out[f"wall_s_to_{name}"] = count, seconds
    out["objective_at_ours_evals"] = evaluator.best_at(evaluations=ours_evals)
    out["objective_at_ours_wall"] = evaluator.best_at(seconds=ours_wall)
    return out


def bench_position(spec, index: int, material: str, args) -> dict:
    """One position target: ours, TPE and GP-BO."""
    from ...inverse.evaluation import SceneEvaluator
    from ...inverse.scenes.position.solve import position_problems, solve_position_target

    paper = PAPER_OBJECTIVES[material][index]
    ours = SceneEvaluator(max(spec.n_units))
    solve_position_target(spec, index, ours)
    mine = _summary(ours, paper, np.inf, np.inf)
    methods = {"ours": mine}
    if not args.no_seeded:
        from ...inverse.scenes.position.spec import with_seeds

        seeded_spec = with_seeds(spec, seed_dataset(spec, args.seed_datasets))
        seeded = SceneEvaluator(max(spec.n_units))  # its clock starts here: after the one-off open
        solve_position_target(seeded_spec, index, seeded)
        methods["ours_seeded"] = _summary(seeded, paper, np.inf, np.inf)
        methods["ours_seeded"]["seeds"] = seeded.counts["seeds"]
    for name, runner, budget in (("tpe", run_tpe, args.tpe_budget), ("gp", run_gp, args.gp_budget)):
        try:
            evaluator = SceneEvaluator(max(spec.n_units))
            problems = {p.n_units: p for p in position_problems(spec, index, evaluator)}
            runner(problems, _position_objective(problems), budget, args.seed)
            methods[name] = _summary(evaluator, paper, mine["evals"], mine["wall_s"])
        except ImportError as exc:
            methods[name] = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
    return _row("position", spec.kind_spec.targets[index].point, material, paper, methods)


def seed_dataset(spec, made: dict[str, dict]) -> str:
    """The seeds dataset of a position scene's height order, swept here if it is missing.

    ``made`` records, per dataset of this run, ``sweep_wall_s`` (None when it existed) and
    ``open_s``: opening it for the process (:func:`dpfexplore.inverse.engine.seeds.open_seeds`: the
    tip index and the design columns of the scene's N), which every later target shares. Both are
    one-off costs of the dataset, reported apart from the per-target rows as the sweep is.
    """
    from ...inverse.engine.seeds import open_seeds

    order = spec.variables.get("heights", "free")
    job = JOBS / f"design-seeds-{order}.toml"
    out = Path("results") / f"design-seeds-{order}"
    if str(out) not in made:
        wall = None
        if not (out / "_manifest.json").is_file():
            from ...sweep.driver import run_sweep
            from ...sweep.job_file import load_job

            begin = time.perf_counter()
            run_sweep(load_job(job), out)
            wall = time.perf_counter() - begin
        begin = time.perf_counter()
        open_seeds(out, tuple(spec.n_units))
        made[str(out)] = {"sweep_wall_s": wall, "open_s": time.perf_counter() - begin}
    return str(out)


def _row(scene: str, target, material: str, paper: float | None, methods: dict) -> dict:
    ours = methods["ours"]
    key = "paper" if paper is not None else "1e-6"
    baselines = {k: v for k, v in methods.items() if not k.startswith("ours") and "error" not in v}
    seeded = methods.get("ours_seeded", {})

    def rank(item):
        v = item[1]
        reached = v.get(f"evals_to_{key}")
        return (reached is None, reached if reached is not None else v["objective"])

    best_name, best = min(baselines.items(), key=rank) if baselines else (None, {})
    return {
        "scene": scene,
        "target": list(target),
        "material": material,
        "paper_objective": paper,
        "ours_evals": ours.get(f"evals_to_{key}"),
        "ours_wall_s": ours.get(f"wall_s_to_{key}"),
        "ours_objective": ours["objective"],
        "ours_total_evals": ours["evals"],
        "ours_total_wall_s": ours["wall_s"],
        "ours_seeded_evals": seeded.get(f"evals_to_{key}"),
        "ours_seeded_wall_s": seeded.get(f"wall_s_to_{key}"),
        "ours_seeded_objective": seeded.get("objective"),
        "best_baseline": best_name,
        "baseline_evals": best.get(f"evals_to_{key}"),
        "baseline_wall_s": best.get(f"wall_s_to_{key}"),
        "baseline_objective": best.get("objective"),
        "baseline_budget_evals": best.get("evals"),
        "methods": methods,
    }


def bench_gripper(args) -> dict:
    """The gripper: ours against the baselines on the apertures' squared error (mm²)."""
    from ...inverse.evaluation import SceneEvaluator
    from ...inverse.kinds import load_scene
    from ...inverse.scenes.gripper.solve import gripper_problem, solve_gripper

    spec = load_scene(JOBS / "design-gripper.toml")
    ours = SceneEvaluator(5)
    result = solve_gripper(spec, 0, ours)
    mine = _summary(ours, 0.05**2, np.inf, np.inf)
    mine["final_objective"] = float(result.best.objective)
    mine["final_stiffness"] = float(result.best.evaluation.stiffness[0])
    methods = {"ours": mine}
    for name, runner in (("tpe", run_tpe), ("gp", run_gp)):
        try:
            evaluator = SceneEvaluator(5)
            problem = gripper_problem(spec, evaluator)

            def f(n, z, problem=problem):
                ev = problem.evaluate(z[None, :], purpose="baseline")
                value = float(ev.objective[0])
                return value if math.isfinite(value) else PENALTY

            runner({5: problem}, f, args.gripper_budget, args.seed)
            methods[name] = _summary(evaluator, 0.05**2, mine["evals"], mine["wall_s"])
        except ImportError as exc:
            methods[name] = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
    return _row("gripper", spec.kind_spec.apertures, spec.material, 0.05**2, methods)


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench design``."""
    from ...inverse.kinds import load_scene, parse_scene

    logging.getLogger("bayes_opt").setLevel(logging.WARNING)
    args.seed_datasets = {}
    rows = []
    started = time.perf_counter()
    targets = [t - 1 for t in args.targets]
    materials = [] if args.skip_position else args.materials
    for material in materials:
        spec = load_scene(JOBS / SCENES[material])
        if args.n_units:
            document = dict(spec.document)
            document["variables"] = {
                **document["variables"],
                "n_units": [int(n) for n in args.n_units.split(",")],
            }
            spec = parse_scene(document, default_name=spec.name)
        for index in targets:
            rows.append(bench_position(spec, index, material, args))
            _progress(rows[-1], started)
    if not args.skip_gripper:
        rows.append(bench_gripper(args))
        _progress(rows[-1], started)
    from .timing import bench_pickplace, bench_walker

    for skip, bench in ((args.skip_pickplace, bench_pickplace), (args.skip_walker, bench_walker)):
        if not skip:
            for row in bench(args, JOBS):
                rows.append(row)
                _progress(row, started)
    record = {
        "benchmark": "design",
        "machine": machine_info(),
        "rows": rows,
        "wall_s": time.perf_counter() - started,
        "summary": _goals(rows),
        "seed_datasets": {
            path: {"designs": _designs_in(path), **facts}
            for path, facts in args.seed_datasets.items()
        },
    }
    save = REPORTS / args.save_as if args.save else None
    emit(record, as_json=args.json, text=_text(record), save=save)
    return 0


def _progress(row: dict, started: float) -> None:
    print(
        f"{time.perf_counter() - started:8.1f} s  {row['scene']} {row['target']} "
        f"{row['material']}: ours {row['ours_objective']:.2e}, {row['best_baseline']} "
        f"{_fmt(row['baseline_objective'], '.2e')}",
        file=sys.stderr,
        flush=True,
    )


def _ratio(a, b):
    if a is None or b is None or a <= 0:
        return None
    return b / a


def _designs_in(path: str) -> int:
    from ...sweep.storage.datasets import dataset_info

    return int(dataset_info(path).designs_committed)


def _goals(rows: list[dict]) -> dict:
    position = [r for r in rows if r["scene"] == "position"]
    out = {
        "position_targets": len(position),
        "position_met_1e-6": sum(r["ours_objective"] <= 1e-6 for r in position),
        "position_max_wall_s": max((r["ours_total_wall_s"] for r in position), default=None),
    }
    ratios = []
    for r in position:
        base_evals = r["baseline_evals"]
        if base_evals is None:  # not reached within the budget: a lower bound
            base_evals = r["baseline_budget_evals"]
        ratios.append(
            {
                "target": r["target"],
                "material": r["material"],
                "evals_ratio": _ratio(r["ours_evals"], base_evals),
                "wall_ratio": _ratio(r["ours_wall_s"], r["baseline_wall_s"]),
                "seeded_evals_ratio": _ratio(r.get("ours_seeded_evals"), base_evals),
                "seeded_wall_ratio": _ratio(r.get("ours_seeded_wall_s"), r["baseline_wall_s"]),
                "baseline_reached_paper": r["baseline_evals"] is not None,
            }
        )
    out["ratios"] = ratios
    timing = [r for r in rows if r["scene"] == "pickplace" or r["scene"].startswith("walker")]
    out["timing_scenes"] = [
        {
            "scene": r["scene"],
            "target": r["target"],
            "ours_wall_s_to_goal": r["ours_wall_s"],
            "tpe_wall_s_to_goal": r["baseline_wall_s"],
            "tpe_objective_at_ours_wall": r["baseline_objective_at_ours_wall"],
            "wall_ratio": r["wall_ratio_to_goal"],
            "ratio_is_lower_bound": r["wall_ratio_is_lower_bound"],
            "goal": r["goal"],
            "goal_tight": r.get("goal_tight"),
            "wall_ratio_to_tight": r.get("wall_ratio_to_tight"),
            "tight_ratio_is_lower_bound": r.get("wall_ratio_to_tight_is_lower_bound"),
        }
        for r in timing
    ]
    return out


def _fmt(v, spec=".3g") -> str:
    return "-" if v is None else format(v, spec)


def _baseline_lines(row: dict) -> list[str]:
    """One line per baseline of a row: its budget and best objective, or why it did not run.

    The table's columns show the best baseline only; these lines keep every baseline visible
    (a GP-BO run that lost to TPE, or one that could not run), so none is dropped silently.
    """
    key = "paper" if row.get("paper_objective") is not None else "1e-6"
    lines = []
    for name, method in row.get("methods", {}).items():
        if name.startswith("ours"):
            continue
        if "error" in method:
            lines.append(f"    {name}: not run: {method['error']}")
            continue
        reached = method.get(f"evals_to_{key}")
        seconds = _fmt(method.get(f"wall_s_to_{key}"), ".2f")
        to_goal = (
            f"reached {key} in {reached} evaluations ({seconds} s)"
            if reached is not None
            else f"did not reach {key}"
        )
        lines.append(
            f"    {name}: {method.get('evals')} evaluations in "
            f"{_fmt(method.get('wall_s'), '.2f')} s, best objective "
            f"{_fmt(method.get('objective'), '.2e')}; {to_goal}"
        )
    return lines


def _text(record: dict) -> str:
    lines = [
        "bench design: evaluations (designs solved) and wall time to reach the paper's "
        "objective; best objective (mm²) within each budget",
        f"{'scene':9} {'target':>14} {'material':>14} {'paper':>6} | {'ours ev':>7} "
        f"{'ours s':>7} {'ours obj':>9} | {'seeded ev':>9} {'s':>6} | {'baseline':>8} "
        f"{'ev':>6} {'s':>7} {'obj':>9} {'budget':>6}",
    ]
    for r in record["rows"]:
        t = "(" + ", ".join(f"{v:g}" for v in r["target"]) + ")"
        lines.append(
            f"{r['scene']:9} {t:>14} {r['material']:>14} {_fmt(r['paper_objective']):>6} | "
            f"{_fmt(r['ours_evals'], 'd'):>7} {_fmt(r['ours_wall_s'], '.3f'):>7} "
            f"{_fmt(r['ours_objective'], '.2e'):>9} | "
            f"{_fmt(r.get('ours_seeded_evals'), 'd'):>9} "
            f"{_fmt(r.get('ours_seeded_wall_s'), '.3f'):>6} | "
            f"{r['best_baseline'] or '-':>8} "
            f"{_fmt(r['baseline_evals'], 'd'):>6} {_fmt(r['baseline_wall_s'], '.2f'):>7} "
            f"{_fmt(r['baseline_objective'], '.2e'):>9} {_fmt(r['baseline_budget_evals'], 'd'):>6}"
        )
        lines.extend(_baseline_lines(r))
    s = record["summary"]
    lines.append(
        f"position targets met to 1e-6 mm²: {s['position_met_1e-6']}/"
        f"{s['position_targets']}; slowest target {_fmt(s['position_max_wall_s'])} s"
    )
    for t in s.get("timing_scenes", []):
        bound = ">= " if t["ratio_is_lower_bound"] else ""
        tight = ""
        if t.get("goal_tight") is not None:
            tight_bound = ">= " if t["tight_ratio_is_lower_bound"] else ""
            tight = (
                f"; to {t['goal_tight']:g}: ratio {tight_bound}"
                f"{_fmt(t['wall_ratio_to_tight'], '.1f')}"
            )
        lines.append(
            f"{t['scene']} {t['target']}: ours {_fmt(t['ours_wall_s_to_goal'], '.2f')} "
            f"s to {t['goal']:g}, TPE {_fmt(t['tpe_wall_s_to_goal'], '.2f')} s; ratio "
            f"{bound}{_fmt(t['wall_ratio'], '.1f')}; TPE's best at our wall time "
            f"{_fmt(t['tpe_objective_at_ours_wall'], '.3g')}{tight}"
        )
    for path, facts in record.get("seed_datasets", {}).items():
        made = (
            "found" if facts["sweep_wall_s"] is None else f"swept in {facts['sweep_wall_s']:.1f} s"
        )
        lines.append(
            f"seeded: candidates from {path} ({facts['designs']:,} designs, {made}, "
            f"opened in {facts['open_s']:.2f} s; neither counted above)"
        )
    lines.append(
        f"total {record['wall_s']:.1f} s on {record['machine']['cores']} cores "
        f"({record['machine']['cpu']})"
    )
    return "\n".join(lines)
