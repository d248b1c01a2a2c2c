"""The timing scenes of ``dpfexplore bench design``: ours against Optuna TPE at equal wall time.

Both methods run on the same exact evaluator (:class:`dpfexplore.inverse.evaluation.SceneEvaluator`)
and are measured by the same objective on the full model:

* **pick-and-place** (``jobs/design-pickplace.toml``, one target reset time at a time): the
  relative error ``|RT / T - 1|`` of the objective reset time, full model (Rodas4 at the scene's
  ``search_atol``) for every TPE trial; a design whose hold units reset (or whose tip units never
  invert) gets :data:`PENALTY`. Goals: the scene's tolerance (1 %) and the tenth of it our search
  stops at (TPE runs until it reaches that, or out of time).
* **walker leg** (``jobs/design-walker-leg.toml``, front and middle leg): the total violation
  of every requirement of the scene (:func:`dpfexplore.inverse.scenes.walker.solve.violation`: 0
  when all are met), each TPE trial a whole leg (three sections simulated, inversion pressures, the
  walking stride against the monostable leg). Goal: 0.

Ours starts from nothing for each row (its screening included). TPE gets ``tpe_factor`` times our
wall time (at least ``min_seconds``) and stops early once it reaches the goal; so when it does not,
the ratio reported is a lower bound. Rows follow :mod:`dpfexplore.bench.design`'s schema.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

#: Objective a black-box trial gets when its design has no objective value.
PENALTY = 1.0e3


def _tpe(objective, dims: int, *, seconds: float, goal: float, seed: int) -> int:
    """Optuna TPE on ``[0, 1]^dims`` for ``seconds``, stopping once the goal is reached."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.TPESampler(seed=seed), direction="minimize")

    def stop(study, trial) -> None:
        if study.best_value <= goal:
            study.stop()

    study.optimize(
        lambda trial: objective(
            np.array([trial.suggest_float(f"z{j}", 0.0, 1.0) for j in range(dims)])
        ),
        timeout=seconds,
        callbacks=[stop],
    )
    return len(study.trials)


def _summary(
    evaluator, goal: float, ours_wall: float = math.inf, tight: float | None = None
) -> dict:
    count, seconds = evaluator.reached(goal)
    out = {
        "evals": evaluator.counts["designs"],
        "wall_s": evaluator.wall_s,
        "objective": evaluator.best_at(),
        "evals_to_goal": count,
        "wall_s_to_goal": seconds,
        "objective_at_ours_wall": evaluator.best_at(seconds=ours_wall),
        "counts": {k: v for k, v in evaluator.counts.items() if v},
    }
    if tight is not None:
        out["evals_to_tight"], out["wall_s_to_tight"] = evaluator.reached(tight)
    return out


def _ratio(ours: dict, tpe: dict, key: str) -> tuple[float | None, bool]:
    """TPE's wall time to a goal over ours (a lower bound when TPE did not reach it)."""
    if not ours.get(key):
        return None, False
    reached = tpe.get(key)
    base = reached if reached is not None else tpe.get("wall_s")
    return (base / ours[key] if base is not None else None), reached is None


def _row(
    scene: str,
    target: list,
    goal: float,
    ours: dict,
    tpe: dict,
    seconds: float,
    tight: float | None = None,
) -> dict:
    reached = tpe.get("wall_s_to_goal")
    ratio, _ = _ratio(ours, tpe, "wall_s_to_goal")
    extra = {}
    if tight is not None:
        tight_ratio, bound = _ratio(ours, tpe, "wall_s_to_tight")
        extra = {
            "goal_tight": tight,
            "ours_wall_s_to_tight": ours.get("wall_s_to_tight"),
            "baseline_wall_s_to_tight": tpe.get("wall_s_to_tight"),
            "wall_ratio_to_tight": tight_ratio,
            "wall_ratio_to_tight_is_lower_bound": bound,
        }
    return {
        **extra,
        "scene": scene,
        "target": target,
        "material": "cheetah-95a",
        "paper_objective": goal,
        "ours_evals": ours.get("evals_to_goal"),
        "ours_wall_s": ours.get("wall_s_to_goal"),
        "ours_objective": ours["objective"],
        "ours_total_evals": ours["evals"],
        "ours_total_wall_s": ours["wall_s"],
        "best_baseline": "tpe" if "error" not in tpe else None,
        "baseline_evals": tpe.get("evals_to_goal"),
        "baseline_wall_s": reached,
        "baseline_objective": tpe.get("objective"),
        "baseline_budget_evals": tpe.get("evals"),
        "baseline_budget_s": seconds,
        "baseline_objective_at_ours_wall": tpe.get("objective_at_ours_wall"),
        "wall_ratio_to_goal": ratio,
        "wall_ratio_is_lower_bound": reached is None,
        "goal": goal,
        "methods": {"ours": ours, "tpe": tpe},
    }


def bench_pickplace(args, jobs) -> list[dict]:
    """Each target reset time: ours (screening + bracket + Brent) against TPE."""
    from ...inverse.evaluation import SceneEvaluator
    from ...inverse.kinds import load_scene
    from ...inverse.scenes.pickplace.problem import ResetProblem
    from ...inverse.scenes.pickplace.solve import SEARCH_FRACTION, solve_pickplace
    from ...inverse.scenes.pickplace.spec import with_target_reset

    base = load_scene(jobs / "design-pickplace.toml")
    rows = []
    for target in [float(v) for v in args.pickplace_targets.split(",") if v]:
        spec = with_target_reset(base, target)
        goal = spec.kind_spec.tolerance
        ours_ev = SceneEvaluator(max(spec.n_units))
        solve_pickplace(spec, 0, ours_ev)
        tight = SEARCH_FRACTION * goal
        ours = _summary(ours_ev, goal, tight=tight)
        seconds = max(args.timing_tpe_factor * ours["wall_s"], args.timing_min_seconds)
        try:
            evaluator = SceneEvaluator(max(spec.n_units))
            problem = ResetProblem(spec, evaluator, target_index=0)

            def f(z, problem=problem, spec=spec, target=target) -> float:
                ev = problem.resets(
                    z[None, :],
                    purpose="baseline",
                    method="rodas4",
                    atol=spec.kind_spec.search_atol,
                    objective_target=target,
                )
                value = float(ev.value[0])
                if not (ev.admissible[0] and math.isfinite(value)):
                    return PENALTY
                return abs(value / target - 1.0)

            _tpe(f, problem.dim, seconds=seconds, goal=tight, seed=args.seed)
            tpe = _summary(evaluator, goal, ours["wall_s"], tight=tight)
        except ImportError as exc:
            tpe = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
        rows.append(_row("pickplace", [target], goal, ours, tpe, seconds, tight))
    return rows


def bench_walker(args, jobs) -> list[dict]:
    """Each leg of the walker scene: ours (section by section, roots) against TPE on the leg."""
    from ...inverse.evaluation import SceneEvaluator
    from ...inverse.kinds import load_scene
    from ...inverse.scenes.walker.solve import WalkerSearch, solve_walker, violation

    base = load_scene(jobs / "design-walker-leg.toml")
    rows = []
    for kind in base.kind_spec.legs:
        spec = replace(base, kind_spec=replace(base.kind_spec, legs=(kind,)))
        ours_ev = SceneEvaluator(4)
        solve_walker(spec, 0, ours_ev)
        ours = _summary(ours_ev, 0.0)
        seconds = max(args.timing_tpe_factor * ours["wall_s"], args.timing_min_seconds)
        try:
            evaluator = SceneEvaluator(4)
            search = WalkerSearch(spec, evaluator)
            variables = spec.kind_spec.variables
            sizes = {role: variables[role].n_variables for role in ("purple", "green", "action")}

            f = _leg_objective(search, variables, sizes, kind, violation)
            _tpe(f, sum(sizes.values()), seconds=seconds, goal=0.0, seed=args.seed)
            tpe = _summary(evaluator, 0.0, ours["wall_s"])
        except ImportError as exc:
            tpe = {"error": f"not installed ({exc.name}): pip install -e '.[baselines]'"}
        rows.append(_row(f"walker-{kind}", [], 0.0, ours, tpe, seconds))
    return rows


def _leg_objective(search, variables, sizes: dict, kind: str, violation):
    """Black-box objective of a whole leg: box point -> requirement violation (recorded)."""
    from ...model.design import DesignBatch

    def f(z) -> float:
        parts, start = {}, 0
        for role, m in sizes.items():
            parts[role] = variables[role].design(z[start : start + m])
            start += m
        value = violation(search.assess(parts["purple"], parts["green"], parts["action"], kind))
        search.evaluator.record(
            DesignBatch.from_designs([parts["purple"]]),
            target=0,
            purpose="baseline",
            section="leg",
            objective=value,
        )
        return value

    return f
