"""Fit and compare surrogates of a dataset: held-out error by design, speed vs the exact model.

:func:`fit_surrogates` holds out a share of the designs (:func:`split_by_design`), fits a
:class:`DesignSurrogate` of each kind and a :class:`StatusClassifier` on the rest, and measures

* the held-out error per output and per N (median, 95th percentile, largest) and the
  accuracy of each status classifier, overall and per N;
* the time per prediction on one core (Numba and BLAS/OpenMP limited to one thread), batched
  (all held-out rows in one call, time per row) and single (one row per call), through the
  public API (a DataFrame of rows in, arrays out);
* the exact model (:func:`dpfexplore.solve_batch`) on the same held-out designs, timed the same
  way; its outputs are compared with the dataset's, which it computed (an error of 0 up to the
  solver's tolerance says the comparison is on the same designs).

The result, a :class:`SurrogateSet`, carries every fitted estimator and a JSON-able report;
:mod:`dpfexplore.surrogates.store` saves and loads it.
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

from ..model.formatting import num
from ..model.limits import MAX_UNITS
from ..solvers.statics import solve_batch
from .chain import CHAIN, ChainStatusClassifier, ChainSurrogate
from .data import (
    TIP,
    TrainingData,
    designs_from_rows,
    held_out_errors,
    split_by_design,
)
from .flat import CLASSIFIER_KINDS, KINDS, DesignSurrogate, StatusClassifier

__all__ = [
    "ALL_CLASSIFIER_KINDS",
    "ALL_KINDS",
    "GOALS",
    "SurrogateSet",
    "fit_surrogates",
    "one_thread",
    "time_per_row",
]

logger = logging.getLogger(__name__)

#: Issue 12's goals on held-out designs of the paper's box: tip error (mm), classifier accuracy,
#: training designs.
GOALS = {
    "tip_median_mm": 0.05,
    "tip_p95_mm": 0.3,
    "classifier_accuracy": 0.99,
    "max_train_designs": 100_000,
}
#: Largest number of held-out rows timed in one batched call, and rows timed one at a time.
TIMED_BATCH = 5000
TIMED_SINGLE = 60
#: Regressor kinds: the flat ones of :mod:`.surrogates` and the chain (:mod:`.chain`).
ALL_KINDS = (*KINDS, CHAIN)
#: Status classifier kinds.
ALL_CLASSIFIER_KINDS = (*CLASSIFIER_KINDS, CHAIN)


@dataclass
class SurrogateSet:
    """Fitted surrogates of one dataset, with their held-out report.

    Attributes
    ----------
    outputs : tuple of str
    units : dict of str to str
    regressors : dict of str to DesignSurrogate or ChainSurrogate
        By kind.
    classifier : StatusClassifier or ChainStatusClassifier
        The status classifier with the highest held-out accuracy, used by :meth:`predict`.
    best : str
        Kind with the smallest 95th-percentile headline error (the tip's when both tip
        coordinates are outputs, else the first output's), the default of :meth:`predict`.
    report : dict
        JSON-able: dataset, split, errors, classifier accuracy, speed table, goals, verdict.
    fingerprint : dict
        :func:`dpfexplore.surrogates.data.dataset_fingerprint` of the training dataset.
    classifiers : dict of str to classifier
        Every fitted status classifier by kind (``classifier`` among them).
    """

    outputs: tuple[str, ...]
    units: dict[str, str]
    regressors: dict[str, DesignSurrogate | ChainSurrogate]
    classifier: StatusClassifier | ChainStatusClassifier
    best: str
    report: dict[str, Any] = field(default_factory=dict)
    fingerprint: dict[str, Any] = field(default_factory=dict)
    classifiers: dict[str, StatusClassifier | ChainStatusClassifier] = field(default_factory=dict)

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
        _check_unit_counts(designs)
        model = self.regressors[kind]
        out = pd.DataFrame(model.predict(designs), columns=list(self.outputs), index=designs.index)
        p_ok = self.classifier.predict_proba(designs)[:, 1]
        out["p_ok"] = p_ok
        out["exists"] = p_ok > 0.5
        out["in_range"] = model.in_range(designs) & self.classifier.in_range(designs)
        return out


def _check_unit_counts(designs: pd.DataFrame) -> None:
    """Refuse rows whose ``n_units`` is not a whole number of units from 1 to ``MAX_UNITS``.

    The estimators cast it to an integer: 3.7 units was predicted as a 3-unit finger and
    flagged in range.
    """
    if "n_units" not in designs.columns:
        raise ValueError("designs: no 'n_units' column (need design rows in the sweep schema)")
    n = pd.to_numeric(designs["n_units"], errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(n) | (n != np.round(n)) | (n < 1) | (n > MAX_UNITS)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"designs row {row}: n_units = {num(designs['n_units'].iloc[row])}: need a whole "
            f"number of units from 1 to {MAX_UNITS}"
        )


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
    predict: Callable[[pd.DataFrame], object],
    frame: pd.DataFrame,
    *,
    repeats: int = 3,
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
        return solve_batch(
            designs_from_rows(rows),
            rows["requested"].to_numpy(dtype=np.int64),
            stiffness=stiffness,
            min_eig=min_eig,
        )

    return predict


def _headline(outputs: Sequence[str]) -> str:
    return TIP if "tip_x" in outputs and "tip_y" in outputs else outputs[0]


def fit_surrogates(
    data: TrainingData,
    *,
    kinds: Sequence[str] = ALL_KINDS,
    classifier_kind: str | Sequence[str] = ("gbt", CHAIN),
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
        Regressor kinds to fit and compare (:data:`ALL_KINDS`).
    classifier_kind : str or sequence of str
        Kind(s) of the status classifier (:data:`ALL_CLASSIFIER_KINDS`); each is fitted and
        reported, and the one with the highest held-out accuracy is the set's ``classifier``.
    per_n : bool
        One model per N (True) or N as a feature.
    test_fraction : float
        Share of the designs held out.
    max_train_designs : int, optional
        Cap on the training designs.
    seed : int
        Seed of the split and the estimators.
    params : dict of str to dict, optional
        Estimator keyword arguments per kind (``"classifier"`` for the flat classifiers,
        ``"chain_classifier"`` for the chain's); the key ``max_train`` sets the subsample size
        instead, and for ``chain`` the keys ``inner`` and ``inner_params`` set its flat model of
        the outputs it does not compose.
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
        return _fit_surrogates(
            data,
            kinds,
            classifier_kind,
            per_n,
            test_fraction,
            max_train_designs,
            seed,
            params,
            timing,
            progress,
        )


def _make_regressor(
    kind: str, outputs: Sequence[str], per_n: bool, seed: int, params: Mapping[str, Any]
) -> DesignSurrogate | ChainSurrogate:
    params = dict(params)
    max_train = params.pop("max_train", None)
    if kind == CHAIN:
        inner = params.pop("inner", "mlp")
        inner_params = params.pop("inner_params", None)
        return ChainSurrogate(
            outputs=tuple(outputs),
            params=params,
            inner=inner,
            inner_params=inner_params,
            max_train=max_train,
            random_state=seed,
        )
    return DesignSurrogate(
        kind=kind, per_n=per_n, random_state=seed, max_train=max_train, params=params
    )


def _make_classifier(kind: str, per_n: bool, seed: int, params: Mapping[str, Any]):
    if kind == CHAIN:
        return ChainStatusClassifier(
            random_state=seed, **dict(params.get("chain_classifier") or {})
        )
    return StatusClassifier(
        kind=kind, per_n=per_n, random_state=seed, params=params.get("classifier")
    )


def _fit_surrogates(
    data,
    kinds,
    classifier_kind,
    per_n,
    test_fraction,
    max_train_designs,
    seed,
    params,
    timing,
    progress,
) -> SurrogateSet:
    say = progress or logger.info
    kinds = list(dict.fromkeys(kinds))
    for kind in kinds:
        if kind not in ALL_KINDS:
            raise ValueError(f"kind {kind!r}: choose from {', '.join(ALL_KINDS)}")
    if not kinds:
        raise ValueError("kinds: none given")
    classifier_kinds = list(
        dict.fromkeys([classifier_kind] if isinstance(classifier_kind, str) else classifier_kind)
    )
    for kind in classifier_kinds:
        if kind not in ALL_CLASSIFIER_KINDS:
            raise ValueError(
                f"classifier kind {kind!r}: choose from {', '.join(ALL_CLASSIFIER_KINDS)}"
            )
    if not classifier_kinds:
        raise ValueError("classifier kinds: none given")
    params = dict(params or {})
    frame, outputs = data.frame, list(data.outputs)
    train, test = split_by_design(
        frame["design_id"].to_numpy(),
        test_fraction=test_fraction,
        seed=seed,
        max_train_designs=max_train_designs,
    )
    ok = data.ok
    if not (train & ok).any() or not (test & ok).any():
        raise ValueError(
            f"{data.root}: no rows whose requested state exists on one side of "
            "the split (too few designs?)"
        )
    train_ok, test_ok = frame[train & ok], frame[test & ok]
    test_all = frame[test]
    n_designs = {
        "train": int(frame.loc[train, "design_id"].nunique()),
        "test": int(test_all["design_id"].nunique()),
    }
    say(
        f"split by design: {n_designs['train']} training designs ({int(train.sum())} rows, "
        f"{len(train_ok)} ok), {n_designs['test']} held out ({int(test.sum())} rows)"
    )

    truth_ok = ok[test]
    test_n = test_all["n_units"].to_numpy()
    classifiers, classifier_records, classifier_seconds = {}, {}, {}
    for kind in classifier_kinds:
        start = time.perf_counter()
        classifier = _make_classifier(kind, per_n, seed, params).fit(frame[train], ok[train])
        classifier_seconds[kind] = time.perf_counter() - start
        predicted_ok = classifier.predict(test_all)
        right = predicted_ok == truth_ok
        classifiers[kind] = classifier
        classifier_records[kind] = {
            "kind": kind,
            "accuracy": float(np.mean(right)),
            "accuracy_per_n": {
                int(n): float(np.mean(right[test_n == n])) for n in np.unique(test_n)
            },
            "missed": int(np.sum(truth_ok & ~predicted_ok)),
            "false_alarms": int(np.sum(~truth_ok & predicted_ok)),
            "test_rows": int(test.sum()),
        }
        say(
            f"classifier ({kind}): held-out accuracy {classifier_records[kind]['accuracy']:.4f}"
            f" ({classifier_seconds[kind]:.1f} s)"
        )
    # Ties go to the first kind given.
    best_classifier = max(classifier_kinds, key=lambda k: classifier_records[k]["accuracy"])
    classifier = classifiers[best_classifier]
    classifier_s = classifier_seconds[best_classifier]

    regressors, fit_seconds, error_tables = {}, {}, []
    y_train = train_ok[outputs].to_numpy(dtype=float)
    for kind in kinds:
        start = time.perf_counter()
        model = _make_regressor(kind, outputs, per_n, seed, params.get(kind) or {}).fit(
            train_ok, y_train
        )
        fit_seconds[kind] = time.perf_counter() - start
        table = held_out_errors(test_ok, model.predict(test_ok), outputs)
        table.insert(0, "model", kind)
        error_tables.append(table)
        regressors[kind] = model
        line = table[(table["output"] == _headline(outputs)) & (table["n_units"] == "all")]
        say(
            f"{kind}: fitted in {fit_seconds[kind]:.1f} s; held-out {_headline(outputs)} error "
            f"median {line['median'].iloc[0]:.4g}, p95 {line['p95'].iloc[0]:.4g}"
        )

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
            for kind, model in classifiers.items():
                batched, single = time_per_row(model.predict, timed)
                speed.append(
                    {
                        "model": f"classifier ({kind})",
                        "us_batched": batched,
                        "us_single": single,
                        "fit_s": classifier_seconds[kind],
                    }
                )
            batched, single = time_per_row(exact, timed)
            speed.append({"model": "exact", "us_batched": batched, "us_single": single})
        for row in speed:
            if row["model"] in pooled.index:
                for stat in ("median", "p95", "max"):
                    row[f"{headline}_{stat}"] = float(pooled.loc[row["model"], stat])
            row.setdefault("fit_s", fit_seconds.get(row["model"], 0.0))

    report = {
        "outputs": outputs,
        "units": dict(data.units),
        "headline": headline,
        "dataset": {
            "path": str(data.root),
            "fingerprint": data.fingerprint,
            "rows": len(frame),
            "designs": int(frame["design_id"].nunique()),
        },
        "split": {
            "by": "design_id",
            "test_fraction": test_fraction,
            "seed": seed,
            "max_train_designs": max_train_designs,
            "train_designs": n_designs["train"],
            "test_designs": n_designs["test"],
            "train_rows_ok": len(train_ok),
            "test_rows_ok": len(test_ok),
        },
        "per_n": per_n,
        "kinds": kinds,
        "best": best,
        "errors": errors.to_dict(orient="records"),
        "classifier": {
            **classifier_records[best_classifier],
            "exact_model_agreement": exact_status_agreement,
        },
        "classifiers": [classifier_records[k] for k in classifier_kinds],
        "fit_seconds": {
            **fit_seconds,
            "classifier": classifier_s,
            **{f"classifier ({k})": v for k, v in classifier_seconds.items()},
        },
        "fit_notes": {
            **{k: m.fit_notes_ for k, m in regressors.items()},
            "classifier": classifier.fit_notes_,
            **{f"classifier ({k})": m.fit_notes_ for k, m in classifiers.items()},
        },
        "speed": speed,
    }
    by_n = errors[
        (errors["model"] == best) & (errors["output"] == headline) & (errors["n_units"] != "all")
    ]
    report["goals"] = _goals(report, pooled.loc[best], by_n, headline)
    report["verdict"] = _verdict(report)
    return SurrogateSet(
        tuple(outputs),
        dict(data.units),
        regressors,
        classifier,
        best,
        report,
        dict(data.fingerprint),
        classifiers,
    )


def _goals(
    report: Mapping[str, Any], best: pd.Series, by_n: pd.DataFrame, headline: str
) -> dict[str, Any]:
    """The issue's goals on all held-out designs, and on the worst N (``n_units`` says which)."""
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


def _verdict(report: Mapping[str, Any]) -> str:
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
