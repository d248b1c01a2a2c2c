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
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ..model.constants_set import DEFAULT
from ..model.formatting import num
from ..model.limits import MAX_UNITS
from .chain import CHAIN, ChainStatusClassifier, ChainSurrogate
from .data import TIP, TrainingData, held_out_errors, split_by_design
from .flat import CLASSIFIER_KINDS, KINDS, DesignSurrogate, StatusClassifier
from .goals import GOALS, goals_of, verdict
from .progress import FitProgress, fit_progress
from .speed import TIMED_BATCH, exact_predict, one_thread, time_per_row

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

    The estimators cast it to an integer: 3.7 units would be predicted as a 3-unit finger and
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
    progress: FitProgress | Callable[[str], None] | None = None,
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
    progress : FitProgress or callable, optional
        Told of each step (:mod:`.progress`): a callable gets one line per step; by default a
        bar when standard error is a terminal, else lines to the module logger.

    Returns
    -------
    SurrogateSet
    """
    from threadpoolctl import threadpool_limits

    shown = fit_progress(progress)
    try:
        kinds, classifier_kinds = _checked_kinds(kinds, classifier_kind)
        options = _FitOptions(
            kinds=kinds,
            classifier_kinds=classifier_kinds,
            per_n=per_n,
            test_fraction=test_fraction,
            max_train_designs=max_train_designs,
            seed=seed,
            params=dict(params or {}),
            timing=timing,
        )
        with threadpool_limits(limits=threads):
            return _fit_surrogates(data, options, shown)
    finally:
        shown.close()


@dataclass(frozen=True)
class _FitOptions:
    """The checked choices of one :func:`fit_surrogates` call (its parameters of those names)."""

    kinds: list[str]
    classifier_kinds: list[str]
    per_n: bool
    test_fraction: float
    max_train_designs: int | None
    seed: int
    params: dict[str, Any]
    timing: bool


def _make_regressor(
    kind: str,
    outputs: Sequence[str],
    per_n: bool,
    seed: int,
    params: Mapping[str, Any],
    constants: Mapping[str, Any] | None,
) -> DesignSurrogate | ChainSurrogate:
    """A regressor of ``kind`` on rows of the constants set ``constants`` (its JSON form)."""
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
            constants=constants,
        )
    return DesignSurrogate(
        kind=kind,
        per_n=per_n,
        random_state=seed,
        max_train=max_train,
        params=params,
        constants=constants,
    )


def _make_classifier(
    kind: str,
    per_n: bool,
    seed: int,
    params: Mapping[str, Any],
    constants: Mapping[str, Any] | None,
):
    """A status classifier of ``kind`` on rows of the constants set ``constants``."""
    if kind == CHAIN:
        return ChainStatusClassifier(
            random_state=seed, constants=constants, **dict(params.get("chain_classifier") or {})
        )
    return StatusClassifier(
        kind=kind,
        per_n=per_n,
        random_state=seed,
        params=params.get("classifier"),
        constants=constants,
    )


@dataclass(frozen=True)
class _Split:
    """The held-out split of a fit: which rows train, which test, and which are ok."""

    train: np.ndarray
    test: np.ndarray
    ok: np.ndarray
    train_ok: pd.DataFrame
    test_ok: pd.DataFrame
    test_all: pd.DataFrame
    n_designs: dict[str, int]


def _checked_kinds(kinds, classifier_kind) -> tuple[list[str], list[str]]:
    """The regressor and classifier kinds, each once, in the order given; unknown ones refused."""
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
    return kinds, classifier_kinds


def _split(data: TrainingData, test_fraction, seed, max_train_designs) -> _Split:
    """Hold out a share of the designs (every row of a design on one side)."""
    frame = data.frame
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
    test_all = frame[test]
    return _Split(
        train=train,
        test=test,
        ok=ok,
        train_ok=frame[train & ok],
        test_ok=frame[test & ok],
        test_all=test_all,
        n_designs={
            "train": int(frame.loc[train, "design_id"].nunique()),
            "test": int(test_all["design_id"].nunique()),
        },
    )


def _fit_classifiers(
    frame, split: _Split, kinds, per_n, seed, params, constants, progress: FitProgress
):
    """Fit each status classifier; its held-out accuracy, overall and per N."""
    truth_ok = split.ok[split.test]
    test_n = split.test_all["n_units"].to_numpy()
    classifiers, records, seconds = {}, {}, {}
    for kind in kinds:
        progress.begin(f"fitting classifier ({kind})")
        start = time.perf_counter()
        classifier = _make_classifier(kind, per_n, seed, params, constants).fit(
            frame[split.train], split.ok[split.train]
        )
        seconds[kind] = time.perf_counter() - start
        predicted_ok = classifier.predict(split.test_all)
        right = predicted_ok == truth_ok
        classifiers[kind] = classifier
        records[kind] = {
            "kind": kind,
            "accuracy": float(np.mean(right)),
            "accuracy_per_n": {
                int(n): float(np.mean(right[test_n == n])) for n in np.unique(test_n)
            },
            "missed": int(np.sum(truth_ok & ~predicted_ok)),
            "false_alarms": int(np.sum(~truth_ok & predicted_ok)),
            "test_rows": int(split.test.sum()),
        }
        progress.step(
            f"classifier ({kind}): held-out accuracy {records[kind]['accuracy']:.4f}"
            f" ({seconds[kind]:.1f} s)"
        )
    return classifiers, records, seconds


def _fit_regressors(
    split: _Split, kinds, outputs, per_n, seed, params, constants, progress: FitProgress
):
    """Fit each regressor; its held-out errors per output and per N."""
    regressors, seconds, tables = {}, {}, []
    y_train = split.train_ok[list(outputs)].astype(float)  # named: the models record outputs_
    headline = _headline(outputs)
    for kind in kinds:
        progress.begin(f"fitting {kind}")
        start = time.perf_counter()
        model = _make_regressor(kind, outputs, per_n, seed, params.get(kind) or {}, constants).fit(
            split.train_ok, y_train
        )
        seconds[kind] = time.perf_counter() - start
        table = held_out_errors(split.test_ok, model.predict(split.test_ok), outputs)
        table.insert(0, "model", kind)
        tables.append(table)
        regressors[kind] = model
        line = table[(table["output"] == headline) & (table["n_units"] == "all")]
        progress.step(
            f"{kind}: fitted in {seconds[kind]:.1f} s; held-out {headline} error "
            f"median {line['median'].iloc[0]:.4g}, p95 {line['p95'].iloc[0]:.4g}"
        )
    return regressors, seconds, tables


def _speed(
    regressors, classifiers, classifier_seconds, fit_seconds, exact, test_ok, pooled, headline
):
    """Time per row of every regressor, classifier and the exact model, on one thread."""
    speed = []
    timed = test_ok.iloc[:TIMED_BATCH]
    with one_thread():
        for kind, model in regressors.items():
            batched, single = time_per_row(model.predict, timed)
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
    return speed


def _fit_surrogates(data, options: _FitOptions, progress: FitProgress) -> SurrogateSet:
    frame, outputs = data.frame, list(data.outputs)
    # every estimator computes its physics features, and the exact model its rows, under the
    # dataset's own set (None: the paper's, which estimators take as their default)
    constants = None if data.constants == DEFAULT else data.constants.to_dict()
    split = _split(data, options.test_fraction, options.seed, options.max_train_designs)
    progress.start(
        len(options.classifier_kinds) + len(options.kinds) + 1 + int(bool(options.timing))
    )
    progress.note(
        f"split by design: {split.n_designs['train']} training designs "
        f"({int(split.train.sum())} rows, {len(split.train_ok)} ok), "
        f"{split.n_designs['test']} held out ({int(split.test.sum())} rows)"
    )
    classifiers, classifier_records, classifier_seconds = _fit_classifiers(
        frame,
        split,
        options.classifier_kinds,
        options.per_n,
        options.seed,
        options.params,
        constants,
        progress,
    )
    # Ties go to the first kind given.
    best_classifier = max(options.classifier_kinds, key=lambda k: classifier_records[k]["accuracy"])
    classifier = classifiers[best_classifier]
    regressors, fit_seconds, error_tables = _fit_regressors(
        split,
        options.kinds,
        outputs,
        options.per_n,
        options.seed,
        options.params,
        constants,
        progress,
    )

    progress.begin("exact model on the held-out designs")
    exact = exact_predict(outputs, data.constants)
    exact_out = exact(split.test_all)
    exact_pred = np.column_stack([exact_out[name] for name in outputs])[split.ok[split.test]]
    table = held_out_errors(split.test_ok, exact_pred, outputs)
    table.insert(0, "model", "exact")
    error_tables.append(table)
    errors = pd.concat(error_tables, ignore_index=True)
    exact_status_agreement = float(np.mean((exact_out["status"] == 0) == split.ok[split.test]))
    progress.step(f"exact model: status agreement {exact_status_agreement:.4f}")

    headline = _headline(outputs)
    pooled = errors[(errors["output"] == headline) & (errors["n_units"] == "all")]
    pooled = pooled.set_index("model")
    best = min(options.kinds, key=lambda k: pooled.loc[k, "p95"])
    speed = []
    if options.timing:
        progress.begin("timing on one thread")
        speed = _speed(
            regressors,
            classifiers,
            classifier_seconds,
            fit_seconds,
            exact,
            split.test_ok,
            pooled,
            headline,
        )
        progress.step("timed on one thread")

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
            "test_fraction": options.test_fraction,
            "seed": options.seed,
            "max_train_designs": options.max_train_designs,
            "train_designs": split.n_designs["train"],
            "test_designs": split.n_designs["test"],
            "train_rows_ok": len(split.train_ok),
            "test_rows_ok": len(split.test_ok),
        },
        "per_n": options.per_n,
        "kinds": options.kinds,
        "best": best,
        "errors": errors.to_dict(orient="records"),
        "classifier": {
            **classifier_records[best_classifier],
            "exact_model_agreement": exact_status_agreement,
        },
        "classifiers": [classifier_records[k] for k in options.classifier_kinds],
        "fit_seconds": {
            **fit_seconds,
            "classifier": classifier_seconds[best_classifier],
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
    report["goals"] = goals_of(report, pooled.loc[best], by_n, headline)
    report["verdict"] = verdict(report)
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
