"""``bench design`` keeps every baseline in its text: a GP-BO run that lost to TPE, or one that
could not run, is a line of its own, never dropped silently (``--gp-budget 20`` did)."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore.bench.design import _row, _text, run_gp


def method(evals: int, objective: float, *, reached: int | None = None) -> dict:
    return {
        "evals": evals,
        "wall_s": 0.5 * evals,
        "objective": objective,
        "evals_to_paper": reached,
        "wall_s_to_paper": None if reached is None else 0.5 * reached,
    }


def record(methods: dict) -> dict:
    row = _row("position", (46.0, 32.0), "cheetah-95a", 0.775, methods)
    return {
        "rows": [row],
        "summary": {"position_met_1e-6": 0, "position_targets": 1, "position_max_wall_s": 1.0},
        "wall_s": 1.0,
        "machine": {"cores": 2, "cpu": "test"},
    }


def lines_of(text: str, name: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip().startswith(f"{name}:")]


def test_a_gp_row_that_loses_to_tpe_is_still_shown():
    ours = method(80, 1e-8, reached=12)
    text = _text(
        record({"ours": ours, "tpe": method(1500, 0.5, reached=900), "gp": method(20, 640.0)})
    )
    # the table's baseline column names the best one only ...
    table_row = next(line for line in text.splitlines() if line.startswith("position"))
    assert " tpe " in table_row and " gp " not in table_row
    # ... and each baseline has its own line, with its budget and best objective
    (gp,) = lines_of(text, "gp")
    assert "20 evaluations" in gp and "6.40e+02" in gp and "did not reach paper" in gp
    (tpe,) = lines_of(text, "tpe")
    assert "1500 evaluations" in tpe and "reached paper in 900 evaluations" in tpe


def test_a_baseline_that_could_not_run_says_why():
    error = "not installed (bayes_opt): pip install -e '.[baselines]'"
    text = _text(record({"ours": method(80, 1e-8), "tpe": method(20, 1.0), "gp": {"error": error}}))
    assert lines_of(text, "gp") == [f"    gp: not run: {error}"]


class Box:
    def __init__(self, dim: int) -> None:
        self.dim = dim


@pytest.mark.parametrize("budget", [1, 20])
def test_gp_runs_its_whole_budget_however_small(budget):
    calls: list[tuple[int, np.ndarray]] = []

    def f(n, z):
        calls.append((n, z))
        return float(np.sum((z - 0.3) ** 2))

    run_gp({2: Box(3), 3: Box(4)}, f, budget, seed=0)
    assert len(calls) == budget
    # the N take turns, and every point lies in the unit box of its N
    assert [n for n, _ in calls] == [(2, 3)[i % 2] for i in range(budget)]
    assert all(z.shape == ((3,) if n == 2 else (4,)) for n, z in calls)
    assert all(np.all((z >= 0) & (z <= 1)) for _, z in calls)
