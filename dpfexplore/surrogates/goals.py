"""The surrogates' goals on held-out designs, and the verdict in plain sentences.

:data:`GOALS` are what a surrogate must reach to stand in for the exact model (tip error in mm,
classifier accuracy, training designs; docs/decisions.md);
:func:`goals_of` checks a fit's report against them, on all held-out designs and on the worst N;
:func:`verdict` says whether any surrogate is faster than the exact model, and at what error.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pandas as pd

from .data import TIP

__all__ = ["GOALS", "goals_of", "verdict"]

#: The goals on held-out designs of the paper's box: tip error (mm), classifier accuracy,
#: training designs.
GOALS = {
    "tip_median_mm": 0.05,
    "tip_p95_mm": 0.3,
    "classifier_accuracy": 0.99,
    "max_train_designs": 100_000,
}


def goals_of(
    report: Mapping[str, Any], best: pd.Series, by_n: pd.DataFrame, headline: str
) -> dict[str, Any]:
    """The goals on all held-out designs, and on the worst N (``n_units`` says which)."""
    goals: dict[str, Any] = {}
    if headline == TIP:
        for stat in ("median", "p95"):
            goal = GOALS[f"tip_{stat}_mm"]
            goals[f"tip_{stat}_mm"] = {
                "goal": goal,
                "value": float(best[stat]),
                "met": bool(best[stat] <= goal),
            }
            if len(by_n):
                worst = by_n.loc[by_n[stat].astype(float).idxmax()]
                goals[f"tip_{stat}_mm_worst_n"] = {
                    "goal": goal,
                    "value": float(worst[stat]),
                    "n_units": int(worst["n_units"]),
                    "met": bool(worst[stat] <= goal),
                }
    accuracy = report["classifier"]["accuracy"]
    goals["classifier_accuracy"] = {
        "goal": GOALS["classifier_accuracy"],
        "value": accuracy,
        "met": bool(accuracy >= GOALS["classifier_accuracy"]),
    }
    per_n = report["classifier"]["accuracy_per_n"]
    if per_n:
        n, value = min(per_n.items(), key=lambda item: item[1])
        goals["classifier_accuracy_worst_n"] = {
            "goal": GOALS["classifier_accuracy"],
            "value": value,
            "n_units": int(n),
            "met": bool(value >= GOALS["classifier_accuracy"]),
        }
    train = report["split"]["train_designs"]
    goals["train_designs"] = {
        "goal": GOALS["max_train_designs"],
        "value": train,
        "met": bool(train <= GOALS["max_train_designs"]),
    }
    return goals


def verdict(report: Mapping[str, Any]) -> str:
    """Plain sentences: is any surrogate faster than the exact model, and at what error."""
    speed = {row["model"]: row for row in report["speed"]}
    if "exact" not in speed:
        return "Speed not measured."
    exact = speed["exact"]
    headline = report["headline"]
    unit = "mm" if headline == TIP else report["units"].get(headline, "")
    lines = [
        f"The exact model takes {exact['us_batched']:.1f} µs per design batched and "
        f"{exact['us_single']:.0f} µs for a single design on one core, with no error."
    ]
    for kind in report["kinds"]:
        row = speed[kind]
        batched = exact["us_batched"] / row["us_batched"]
        single = exact["us_single"] / row["us_single"]
        relation = (
            f"{batched:.1f}x faster than the exact model batched"
            if batched > 1
            else f"{1 / batched:.1f}x slower than the exact model batched"
        )
        relation += (
            f", {single:.1f}x faster single" if single > 1 else f", {1 / single:.1f}x slower single"
        )
        lines.append(
            f"{kind}: {relation}, at a held-out {headline} error of "
            f"{row[f'{headline}_median']:.3g} {unit} median, "
            f"{row[f'{headline}_p95']:.3g} {unit} p95."
        )
    faster = [k for k in report["kinds"] if speed[k]["us_batched"] < exact["us_batched"]]
    if not faster:
        lines.append(
            "No surrogate is faster than the exact model: call the exact model "
            "(solve_batch) instead; the surrogates only add error."
        )
    else:
        lines.append(
            f"Faster than the exact model batched: {', '.join(faster)}; each at the "
            "error above, where the exact model has none."
        )
    return " ".join(lines)
