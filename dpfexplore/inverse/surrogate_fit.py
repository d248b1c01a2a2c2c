"""Fit and compare surrogates of a dataset: held-out error by design, speed vs the exact model.

:func:`fit_surrogates` holds out a share of the designs (:func:`split_by_design`), fits a
:class:`DesignSurrogate` of each kind and a :class:`StatusClassifier` on the rest, and measures

* the held-out error per output and per N (median, 95th percentile, largest) and the
  classifier's accuracy;
* the time per prediction on one core (Numba and BLAS/OpenMP limited to one thread), batched
  (all held-out rows in one call, time per row) and single (one row per call), through the
  public API (a DataFrame of rows in, arrays out);
* the exact model (:func:`dpfexplore.solve_batch`) on the same held-out designs, timed the same
  way; its outputs are compared with the dataset's, which it computed (an error of 0 up to the
  solver's tolerance says the comparison is on the same designs).

The result, a :class:`SurrogateSet`, carries every fitted estimator and a JSON-able report;
:mod:`dpfexplore.inverse.surrogate_store` saves and loads it.
"""

from __future__ import annotations

import logging
import statistics
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..solvers.statics import solve_batch
from .surrogate_data import (
    TIP,
    TrainingData,
    designs_from_rows,
    held_out_errors,
    split_by_design,
)
from .surrogates import KINDS, DesignSurrogate, StatusClassifier

__all__ = ["GOALS", "SurrogateSet", "fit_surrogates", "one_thread", "time_per_row"]

logger = logging.getLogger(__name__)

#: Issue 12's goals on held-out designs of the paper's box: tip error (mm), classifier accuracy,
#: training designs.
GOALS = {"tip_median_mm": 0.05, "tip_p95_mm": 0.3, "classifier_accuracy": 0.99,
         "max_train_designs": 100_000}
#: Largest number of held-out rows timed in one batched call, and rows timed one at a time.
TIMED_BATCH = 5000
TIMED_SINGLE = 60


@dataclass
class SurrogateSet:
    """Fitted surrogates of one dataset, with their held-out report.

    Attributes
    ----------
    outputs : tuple of str
    units : dict of str to str
    regressors : dict of str to DesignSurrogate
        By kind.
    classifier : StatusClassifier
    best : str
        Kind with the smallest 95th-percentile headline error (the tip's when both tip
        coordinates are outputs, else the first output's), the default of :meth:`predict`.
    report : dict
        JSON-able: dataset, split, errors, classifier accuracy, speed table, goals, verdict.
    fingerprint : dict
        :func:`dpfexplore.inverse.surrogate_data.dataset_fingerprint` of the training dataset.
    """

    outputs: tuple[str, ...]
    units: dict[str, str]
    regressors: dict[str, DesignSurrogate]
    classifier: StatusClassifier
    best: str
    report: dict[str, Any] = field(default_factory=dict)
    fingerprint: dict[str, Any] = field(default_factory=dict)

    def predict(self, designs: pd.DataFrame, *, kind: str | None = None) -> pd.DataFrame:
        """Predicted outputs with the status probability and the in-range flag.

        Parameters
        ----------
        designs : DataFrame of design rows (sweep-schema design columns)
        kind : str, optional
            Which regressor (default :attr:`best`).

        Returns
        -------
        DataFrame
            One row per design row: the outputs, ``p_ok`` (probability that the requested
            state exists), ``exists`` (``p_ok > 0.5``) and ``in_range`` (False: outside the box
            the surrogate was fitted on, not to be trusted).
        """
        kind = kind or self.best
        if kind not in self.regressors:
            raise ValueError(f"kind = {kind!r}: this surrogate has {', '.join(self.regressors)}")
        model = self.regressors[kind]
        out = pd.DataFrame(model.predict(designs), columns=list(self.outputs),
                           index=designs.index)
        p_ok = self.classifier.predict_proba(designs)[:, 1]
        out["p_ok"] = p_ok
        out["exists"] = p_ok > 0.5
        out["in_range"] = model.in_range(designs) & self.classifier.in_range(designs)
        return out


@contextmanager
def one_thread() -> Iterator[None]:
    """Limit Numba and BLAS/OpenMP (scikit-learn) to one thread inside the block."""
    import numba
    from threadpoolctl import threadpool_limits

    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        numba.set_num_threads(previous)


def _median_seconds(func: Callable[[], object], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def time_per_row(
    predict: Callable[[pd.DataFrame], object], frame: pd.DataFrame, *, repeats: int = 3,
    single_rows: int = TIMED_SINGLE,
) -> tuple[float, float]:
    """Microseconds per row of ``predict``: batched (one call on ``frame``) and single.

    Returns
    -------
    batched_us, single_us : float
        Median over ``repeats`` calls on the whole frame, divided by its rows; median over
        ``single_rows`` rows of one call each (after one warm-up call).
    """
    predict(frame.iloc[:1])
    batched = _median_seconds(lambda: predict(frame), repeats) / len(frame) * 1e6
    rows = [frame.iloc[[i]] for i in range(min(single_rows, len(frame)))]
    single = []
    for row in rows:
        start = time.perf_counter()
        predict(row)
        single.append(time.perf_counter() - start)
    return batched, statistics.median(single) * 1e6


def _exact_predict(outputs: Sequence[str]) -> Callable[[pd.DataFrame], dict[str, NDArray]]:
    """The exact model as a predictor of sweep rows (their requested states)."""
    stiffness, min_eig = "stiffness" in outputs, "min_eig" in outputs

    def predict(rows: pd.DataFrame) -> dict[str, NDArray]:
        return solve_batch(designs_from_rows(rows), rows["requested"].to_numpy(dtype=np.int64),
                           stiffness=stiffness, min_eig=min_eig)

    return predict


def _headline(outputs: Sequence[str]) -> str:
    return TIP if "tip_x" in outputs and "tip_y" in outputs else outputs[0]


def fit_surrogates(
    data: TrainingData,
    *,
    kinds: Sequence[str] = KINDS,
    classifier_kind: str = "gbt",
    per_n: bool = True,
    test_fraction: float = 1 / 6,
    max_train_designs: int | None = GOALS["max_train_designs"],
    seed: int = 0,
    params: Mapping[str, Mapping[str, Any]] | None = None,
    timing: bool = True,
    threads: int | None = 1,
    progress: Callable[[str], None] | None = None,
) -> SurrogateSet:
    """Fit surrogates of ``data`` and report their held-out error and speed.

    Parameters
    ----------
    data : TrainingData
    kinds : sequence of str
        Regressor kinds to fit and compare (:data:`KINDS`).
    classifier_kind : str
        Kind of the status classifier.
    per_n : bool
        One model per N (True) or N as a feature.
    test_fraction : float
        Share of the designs held out.
    max_train_designs : int, optional
        Cap on the training designs.
    seed : int
        Seed of the split and the estimators.
    params : dict of str to dict, optional
        Estimator keyword arguments per kind (``"classifier"`` for the classifier); the key
        ``max_train`` sets :class:`DesignSurrogate`'s subsample size instead.
    timing : bool
        Measure the speed table (a few seconds per kind); False leaves it empty.
    threads : int or None
        BLAS/OpenMP threads of the scikit-learn fits (None: the libraries' default). One by
        default: on a loaded machine OpenMP's spinning threads made gradient-boosted trees 30x
        slower with two threads than with one.
    progress : callable, optional
        Called with a line of text at each step (default: the module logger).

    Returns
    -------
    SurrogateSet
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=threads):
        return _fit_surrogates(data, kinds, classifier_kind, per_n, test_fraction,
                               max_train_designs, seed, params, timing, progress)


def _fit_surrogates(data, kinds, classifier_kind, per_n, test_fraction, max_train_designs, seed,
                    params, timing, progress) -> SurrogateSet:
    say = progress or logger.info
    kinds = list(dict.fromkeys(kinds))
    for kind in kinds:
        if kind not in KINDS:
            raise ValueError(f"kind {kind!r}: choose from {', '.join(KINDS)}")
    if not kinds:
        raise ValueError("kinds: none given")
    params = dict(params or {})
    frame, outputs = data.frame, list(data.outputs)
    train, test = split_by_design(frame["design_id"].to_numpy(), test_fraction=test_fraction,
                                  seed=seed, max_train_designs=max_train_designs)
    ok = data.ok
    if not (train & ok).any() or not (test & ok).any():
        raise ValueError(f"{data.root}: no rows whose requested state exists on one side of "
                         "the split (too few designs?)")
    train_ok, test_ok = frame[train & ok], frame[test & ok]
    test_all = frame[test]
    n_designs = {
        "train": int(frame.loc[train, "design_id"].nunique()),
        "test": int(test_all["design_id"].nunique()),
    }
    say(f"split by design: {n_designs['train']} training designs ({int(train.sum())} rows, "
        f"{len(train_ok)} ok), {n_designs['test']} held out ({int(test.sum())} rows)")

    start = time.perf_counter()
    classifier = StatusClassifier(kind=classifier_kind, per_n=per_n, random_state=seed,
                                  params=params.get("classifier")).fit(frame[train], ok[train])
    classifier_s = time.perf_counter() - start
    predicted_ok = classifier.predict(test_all)
    truth_ok = ok[test]
    per_n_accuracy = {
        int(n): float(np.mean(predicted_ok[rows] == truth_ok[rows]))
        for n in np.unique(test_all["n_units"])
        for rows in [test_all["n_units"].to_numpy() == n]
    }
    accuracy = float(np.mean(predicted_ok == truth_ok))
    say(f"classifier ({classifier_kind}): held-out accuracy {accuracy:.4f} "
        f"({classifier_s:.1f} s)")

    regressors, fit_seconds, error_tables = {}, {}, []
    y_train = train_ok[outputs].to_numpy(dtype=float)
    for kind in kinds:
        start = time.perf_counter()
        kind_params = dict(params.get(kind) or {})
        max_train = kind_params.pop("max_train", None)
        model = DesignSurrogate(kind=kind, per_n=per_n, random_state=seed, max_train=max_train,
                                params=kind_params).fit(train_ok, y_train)
        fit_seconds[kind] = time.perf_counter() - start
        table = held_out_errors(test_ok, model.predict(test_ok), outputs)
        table.insert(0, "model", kind)
        error_tables.append(table)
        regressors[kind] = model
        line = table[(table["output"] == _headline(outputs)) & (table["n_units"] == "all")]
        say(f"{kind}: fitted in {fit_seconds[kind]:.1f} s; held-out {_headline(outputs)} error "
            f"median {line['median'].iloc[0]:.4g}, p95 {line['p95'].iloc[0]:.4g}")

    exact = _exact_predict(outputs)
    exact_out = exact(test_all)
    exact_pred = np.column_stack([exact_out[name] for name in outputs])[ok[test]]
    table = held_out_errors(test_ok, exact_pred, outputs)
    table.insert(0, "model", "exact")
    error_tables.append(table)
    errors = pd.concat(error_tables, ignore_index=True)
    exact_status_agreement = float(np.mean((exact_out["status"] == 0) == truth_ok))

    headline = _headline(outputs)
    pooled = errors[(errors["output"] == headline) & (errors["n_units"] == "all")]
    pooled = pooled.set_index("model")
    best = min(kinds, key=lambda k: pooled.loc[k, "p95"])

    speed = []
    if timing:
        say("timing on one thread ...")
        timed = test_ok.iloc[:TIMED_BATCH]
        with one_thread():
            for kind in kinds:
                batched, single = time_per_row(regressors[kind].predict, timed)
                speed.append({"model": kind, "us_batched": batched, "us_single": single})
            batched, single = time_per_row(classifier.predict, timed)
            speed.append({"model": f"classifier ({classifier_kind})", "us_batched": batched,
                          "us_single": single})
            batched, single = time_per_row(exact, timed)
            speed.append({"model": "exact", "us_batched": batched, "us_single": single})
        for row in speed:
            if row["model"] in pooled.index:
                for stat in ("median", "p95", "max"):
                    row[f"{headline}_{stat}"] = float(pooled.loc[row["model"], stat])
            row["fit_s"] = fit_seconds.get(row["model"], classifier_s
                                           if row["model"].startswith("classifier") else 0.0)

    report = {
        "outputs": outputs,
        "units": dict(data.units),
        "headline": headline,
        "dataset": {"path": str(data.root), "fingerprint": data.fingerprint,
                    "rows": len(frame), "designs": int(frame["design_id"].nunique())},
        "split": {"by": "design_id", "test_fraction": test_fraction, "seed": seed,
                  "max_train_designs": max_train_designs, "train_designs": n_designs["train"],
                  "test_designs": n_designs["test"], "train_rows_ok": len(train_ok),
                  "test_rows_ok": len(test_ok)},
        "per_n": per_n,
        "kinds": kinds,
        "best": best,
        "errors": errors.to_dict(orient="records"),
        "classifier": {"kind": classifier_kind, "accuracy": accuracy,
                       "accuracy_per_n": per_n_accuracy, "test_rows": int(test.sum()),
                       "exact_model_agreement": exact_status_agreement},
        "fit_seconds": {**fit_seconds, "classifier": classifier_s},
        "fit_notes": {**{k: m.fit_notes_ for k, m in regressors.items()},
                      "classifier": classifier.fit_notes_},
        "speed": speed,
    }
    report["goals"] = _goals(report, pooled.loc[best], headline)
    report["verdict"] = _verdict(report)
    return SurrogateSet(tuple(outputs), dict(data.units), regressors, classifier, best,
                        report, dict(data.fingerprint))


def _goals(report: Mapping[str, Any], best: pd.Series, headline: str) -> dict[str, Any]:
    goals: dict[str, Any] = {}
    if headline == TIP:
        goals["tip_median_mm"] = {"goal": GOALS["tip_median_mm"], "value": float(best["median"]),
                                  "met": bool(best["median"] <= GOALS["tip_median_mm"])}
        goals["tip_p95_mm"] = {"goal": GOALS["tip_p95_mm"], "value": float(best["p95"]),
                               "met": bool(best["p95"] <= GOALS["tip_p95_mm"])}
    accuracy = report["classifier"]["accuracy"]
    goals["classifier_accuracy"] = {"goal": GOALS["classifier_accuracy"], "value": accuracy,
                                    "met": bool(accuracy >= GOALS["classifier_accuracy"])}
    train = report["split"]["train_designs"]
    goals["train_designs"] = {"goal": GOALS["max_train_designs"], "value": train,
                              "met": bool(train <= GOALS["max_train_designs"])}
    return goals


def _verdict(report: Mapping[str, Any]) -> str:
    """Plain sentences: is any surrogate faster than the exact model, and at what error."""
    speed = {row["model"]: row for row in report["speed"]}
    if "exact" not in speed:
        return "Speed not measured."
    exact = speed["exact"]
    headline = report["headline"]
    unit = "mm" if headline == TIP else report["units"].get(headline, "")
    lines = [f"The exact model takes {exact['us_batched']:.1f} µs per design batched and "
             f"{exact['us_single']:.0f} µs for a single design on one core, with no error."]
    for kind in report["kinds"]:
        row = speed[kind]
        batched = exact["us_batched"] / row["us_batched"]
        single = exact["us_single"] / row["us_single"]
        relation = (f"{batched:.1f}x faster than the exact model batched" if batched > 1
                    else f"{1 / batched:.1f}x slower than the exact model batched")
        relation += (f", {single:.1f}x faster single" if single > 1
                     else f", {1 / single:.1f}x slower single")
        lines.append(f"{kind}: {relation}, at a held-out {headline} error of "
                     f"{row[f'{headline}_median']:.3g} {unit} median, "
                     f"{row[f'{headline}_p95']:.3g} {unit} p95.")
    faster = [k for k in report["kinds"] if speed[k]["us_batched"] < exact["us_batched"]]
    if not faster:
        lines.append("No surrogate is faster than the exact model: call the exact model "
                     "(solve_batch) instead; the surrogates only add error.")
    else:
        lines.append(f"Faster than the exact model batched: {', '.join(faster)}; each at the "
                     "error above, where the exact model has none.")
    return " ".join(lines)
