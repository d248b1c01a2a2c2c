"""Surrogates of sweep outputs: scikit-learn estimators over design parameters.

A surrogate predicts a design-state's outputs (tip position, curvature, stiffness, ...) from the
design's parameters, and :class:`StatusClassifier` predicts whether the requested state exists
(``ok``) or collapses to another one. Both take a :class:`pandas.DataFrame` of design rows in
the sweep schema (``n_units``, ``H_k``, ``U_L_k``, ``U_sep_k``, ``t``, ``t_lim``, ``E``, ``nu``,
``r_b``, ``t_ch`` and, for datasets of several states per design, ``requested``).

Method
------
Features, per number of units ``N``: the design variables that vary in the training rows of
that ``N`` (``3 N + 2`` in the paper's box); three closed forms per dome (MODEL.md §3-§4,
microseconds for a batch): its energy ratio ``alpha`` (whether a dome is bistable on its own is
the first thing the existence of the all-inverted state depends on), its reach ``d`` and its
isolated inverted extension ``u_2 d`` (``u_2`` = 3/4 without an inverted minimum), which set how
far an inverted unit bends the finger; and, when the training rows request several states, the
requested state's bits. Variables constant in the training rows
(``E``, ``nu``, ``r_b``, ``t_ch`` in a sweep of one material) are recorded with their value.
Inputs are scaled per ``N`` to ``[0, 1]`` on the training box and targets standardised per
``N``; one model is fitted per ``N`` (``per_n=True``, the default) or one for all ``N`` with the
scaled ``N`` as a feature and absent units' features set to 0 (``per_n=False``).

Kinds (:data:`KINDS`): ``knn`` (distance-weighted nearest neighbours: exact on its training
points), ``gbt`` (histogram gradient-boosted trees, one per output), ``mlp`` (a multilayer
perceptron, Adam) and ``gp`` (a Gaussian process with an anisotropic RBF kernel plus white noise,
fitted on a random subsample of at most ``max_train`` rows per model: its cost grows as the cube
of the rows).

Guarantees and limits: a prediction is trusted only inside the box the surrogate was fitted on;
:meth:`DesignSurrogate.in_range` flags every other row (unknown ``N``, a variable outside its
training range, a fixed variable with another value), and :meth:`predict` returns NaN for an
``N`` it was not fitted on. The error of a surrogate is what its held-out report says
(:mod:`dpfexplore.surrogates.fit`); nothing here bounds it.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, ClassifierMixin, RegressorMixin
from sklearn.exceptions import ConvergenceWarning

from ..model.constants import dome_extrema
from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.design import PER_UNIT_FIELDS, SHARED_FIELDS

__all__ = [
    "CLASSIFIER_KINDS",
    "KINDS",
    "DesignSurrogate",
    "StatusClassifier",
    "design_column_names",
]

#: Regressor kinds, in the order reports list them.
KINDS = ("knn", "gbt", "mlp", "gp")
#: Classifier kinds.
CLASSIFIER_KINDS = ("gbt", "mlp")
#: Relative slack of the training-range check (rounding of values read back from files).
RANGE_SLACK = 1e-9
#: Rows a Gaussian process is fitted on by default (its fit costs O(rows^3) time and its
#: hyperparameter gradient O(rows^2 * features) memory).
GP_MAX_TRAIN = 500

ArrayLike2D = NDArray | Sequence[Sequence[float]]


def design_column_names(n_units: int) -> list[str]:
    """Sweep-schema columns that describe a design of ``n_units`` units."""
    per_unit = [f"{name}_{k}" for name in PER_UNIT_FIELDS for k in range(1, n_units + 1)]
    return [*per_unit, *SHARED_FIELDS]


def _state_bits(requested: NDArray, n_units: int) -> NDArray:
    """Bits of requested states, unit 1 (most significant bit) first: shape (n, n_units)."""
    shifts = np.arange(n_units - 1, -1, -1)
    return ((np.asarray(requested, dtype=np.int64)[:, None] >> shifts) & 1).astype(float)


def constants_set_of(constants: Mapping[str, Any] | None) -> ConstantsSet:
    """An estimator's constants set from its JSON form (verified); None: the paper's."""
    return DEFAULT if constants is None else ConstantsSet.from_dict(constants)


def _raw_features(
    frame: pd.DataFrame, n_units: int, use_state: bool, constants: ConstantsSet
) -> tuple[NDArray, list[str]]:
    """Design variables, isolated-dome features and (optionally) state bits of rows of one N.

    The dome features come from ``constants``, the set the rows were computed under.
    """
    names = design_column_names(n_units)
    missing = [c for c in names if c not in frame.columns]
    if missing:
        raise ValueError(f"designs: missing column {missing[0]!r} (N = {n_units})")
    values = frame[names].to_numpy(dtype=float)
    H, U_sep = values[:, :n_units], values[:, 2 * n_units : 3 * n_units]
    t, r_b, E, t_ch = (frame[c].to_numpy(dtype=float)[:, None] for c in ("t", "r_b", "E", "t_ch"))
    with np.errstate(all="ignore"):
        springs = constants.springs(H, t, r_b, E, U_sep, t_ch)
        alpha, reach = springs["alpha"], springs["d"]
        inverted = np.nan_to_num(dome_extrema(alpha)[1], nan=0.75) * reach
    names = [
        *names,
        *(f"{stem}_{k}" for stem in ("alpha", "reach", "inverted") for k in range(1, n_units + 1)),
    ]
    parts = [values, alpha, reach, inverted]
    if use_state:
        if "requested" not in frame.columns:
            raise ValueError(
                "designs: missing column 'requested' (the model was fitted on "
                "several requested states per design)"
            )
        parts.append(_state_bits(frame["requested"].to_numpy(), n_units))
        names += [f"state_{k}" for k in range(1, n_units + 1)]
    return np.column_stack(parts), names


def _check_frame(X: Any) -> pd.DataFrame:
    if not isinstance(X, pd.DataFrame):
        raise ValueError(f"X: need a pandas DataFrame of design rows, got {type(X).__name__}")
    if "n_units" not in X.columns:
        raise ValueError("X: missing column 'n_units'")
    return X


def _make_estimator(kind: str, task: str, params: Mapping[str, Any], seed: int, n_rows: int):
    """A fresh scikit-learn estimator of ``kind`` for ``task`` ('regress' or 'classify')."""
    params = dict(params)
    if kind == "knn" and task == "regress":
        from sklearn.neighbors import KNeighborsRegressor

        # A k-d tree computes distances directly; the brute-force path expands |x - y|^2 and
        # puts a training point ~1e-8 from itself, so distance weights would not be exact there.
        return KNeighborsRegressor(
            **{"n_neighbors": 8, "weights": "distance", "algorithm": "kd_tree", **params}
        )
    if kind == "gbt":
        from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor

        defaults = {
            "max_iter": 500,
            "learning_rate": 0.1,
            "max_leaf_nodes": 31,
            "early_stopping": False,
            "random_state": seed,
        }
        if task == "classify":
            return HistGradientBoostingClassifier(**{**defaults, **params})
        from sklearn.multioutput import MultiOutputRegressor

        return MultiOutputRegressor(HistGradientBoostingRegressor(**{**defaults, **params}))
    if kind == "mlp":
        from sklearn.neural_network import MLPClassifier, MLPRegressor

        defaults = {
            "hidden_layer_sizes": (128, 128),
            "batch_size": 256,
            "max_iter": 500,
            "learning_rate_init": 2e-3,
            "tol": 1e-6,
            "n_iter_no_change": 20,
            "random_state": seed,
        }
        cls = MLPClassifier if task == "classify" else MLPRegressor
        merged = {**defaults, **params}
        merged["batch_size"] = min(merged["batch_size"], n_rows)
        return cls(**merged)
    if kind == "gp" and task == "regress":
        from sklearn.gaussian_process import GaussianProcessRegressor

        return GaussianProcessRegressor(**{"normalize_y": False, "random_state": seed, **params})
    raise ValueError(f"kind = {kind!r}: not a {task} kind")


def _fit_quietly(model: Any, Z: NDArray, T: NDArray, notes: list[str], n: int) -> Any:
    """Fit ``model``, keeping convergence warnings in ``notes`` rather than raising them.

    An MLP stopped by ``max_iter`` or a GP length scale at its bound is reported with the fit;
    the held-out error is the judge of the result.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        model.fit(Z, T)
    for warning in caught:
        if issubclass(warning.category, ConvergenceWarning):
            notes.append(f"N={n}: {str(warning.message).splitlines()[0]}")
        else:
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    _flush_subnormals(model)
    return model


def _flush_subnormals(model: Any) -> None:
    """Set subnormal weights of a fitted MLP to zero (in place).

    The L2 penalty decays the weights of dead units toward zero, and after ~100 epochs hundreds
    of them are subnormal (< 2.2e-308): products with them run ~10x slower on x86, which made a
    chain surrogate's batched prediction 20 µs per design instead of 3. Values that small
    change no prediction.
    """
    for name in ("coefs_", "intercepts_"):
        for weights in getattr(model, name, ()):
            weights[np.abs(weights) < np.finfo(weights.dtype).tiny] = 0.0


class _DesignModel(BaseEstimator):
    """Feature handling shared by the regressor and the classifier (fitted attributes end in _)."""

    def _fit_features(self, X: pd.DataFrame) -> dict[int, NDArray]:
        """Choose features per N, record the training box; scaled features per N (row masks)."""
        X = _check_frame(X)
        chosen = constants_set_of(self.constants)
        n_units = X["n_units"].to_numpy(dtype=np.int64)
        use_state = "requested" in X.columns and any(
            X.loc[n_units == n, "requested"].nunique() > 1 for n in np.unique(n_units)
        )
        self.use_state_ = bool(use_state)
        self.n_units_ = tuple(int(n) for n in np.unique(n_units))
        self.feature_names_: dict[int, list[str]] = {}
        self.fixed_: dict[int, dict[str, float]] = {}
        self.lower_: dict[int, NDArray] = {}
        self.upper_: dict[int, NDArray] = {}
        self.n_train_: dict[int, int] = {}
        self.varying_: dict[int, NDArray] = {}
        scaled = {}
        for n in self.n_units_:
            rows = n_units == n
            raw, names = _raw_features(X.loc[rows], n, self.use_state_, chosen)
            if not np.all(np.isfinite(raw)):
                raise ValueError(f"X: non-finite design values among the rows of N = {n}")
            lo, hi = raw.min(axis=0), raw.max(axis=0)
            varying = hi > lo
            self.feature_names_[n] = [c for c, v in zip(names, varying, strict=True) if v]
            self.fixed_[n] = {
                c: float(v) for c, v, var in zip(names, lo, varying, strict=True) if not var
            }
            self.lower_[n], self.upper_[n] = lo[varying], hi[varying]
            self.n_train_[n] = int(rows.sum())
            self.varying_[n] = varying
            scaled[n] = self._scale(raw, n)
        return scaled

    def _scale(self, raw: NDArray, n: int) -> NDArray:
        lo, hi = self.lower_[n], self.upper_[n]
        return (raw[:, self.varying_[n]] - lo) / (hi - lo)

    def _features(self, X: pd.DataFrame) -> tuple[NDArray, dict[int, NDArray], NDArray]:
        """Row N, scaled features per fitted N, and whether each row is inside the box."""
        X = _check_frame(X)
        chosen = constants_set_of(self.constants)
        n_units = X["n_units"].to_numpy(dtype=np.int64)
        inside = np.zeros(len(X), dtype=bool)
        scaled = {}
        for n in np.unique(n_units):
            n = int(n)
            if n not in self.lower_:
                continue
            rows = n_units == n
            raw, names = _raw_features(X.loc[rows], n, self.use_state_, chosen)
            z = self._scale(raw, n)
            fixed = raw[:, ~self.varying_[n]]
            want = np.array(
                [self.fixed_[n][c] for c, v in zip(names, self.varying_[n], strict=True) if not v]
            )
            ok = np.all((z >= -RANGE_SLACK) & (z <= 1.0 + RANGE_SLACK), axis=1)
            ok &= np.all(
                np.abs(fixed - want) <= RANGE_SLACK * np.maximum(1.0, np.abs(want)), axis=1
            )
            inside[rows] = ok & np.all(np.isfinite(raw), axis=1)
            scaled[n] = np.nan_to_num(z)
        return n_units, scaled, inside

    def _shared_matrix(self, scaled: Mapping[int, NDArray]) -> NDArray:
        """One matrix for all N (``per_n=False``): features padded to the widest N, plus N."""
        width = max(len(self.feature_names_[n]) for n in self.n_units_)
        lo_n, hi_n = min(self.n_units_), max(self.n_units_)
        blocks = []
        for n, z in scaled.items():
            block = np.zeros((z.shape[0], width + 1))
            block[:, : z.shape[1]] = z
            block[:, width] = (n - lo_n) / (hi_n - lo_n) if hi_n > lo_n else 0.0
            blocks.append(block)
        return np.vstack(blocks)

    def in_range(self, X: pd.DataFrame) -> NDArray[np.bool_]:
        """Whether each row lies in the box the model was fitted on (else: do not trust it).

        Parameters
        ----------
        X : DataFrame of design rows

        Returns
        -------
        ndarray of bool, shape (n_rows,)
            False for an ``N`` not fitted, a variable (or dome ``alpha``) outside its training
            range, or a variable that was fixed in training with another value here.
        """
        return self._features(X)[2]


class DesignSurrogate(RegressorMixin, _DesignModel):
    """Regression of sweep outputs on design parameters (one model per N by default).

    Parameters
    ----------
    kind : {"knn", "gbt", "mlp", "gp"}
        The estimator (see the module docstring).
    per_n : bool
        One model per number of units (True) or one model for all, with N as a feature.
    params : dict, optional
        Keyword arguments passed to the scikit-learn estimator, over this module's defaults.
    max_train : int, optional
        Fit each model on at most this many rows (a random subsample); default:
        :data:`GP_MAX_TRAIN` for
        ``gp``, all rows otherwise.
    random_state : int
        Seed of the subsample and of the estimators.
    constants : dict, optional
        The constants set of the rows (its JSON form,
        :meth:`~dpfexplore.model.constants_set.ConstantsSet.to_dict`; verified when used): the
        dome features are its ``alpha`` and reach. None: the paper's.

    Attributes
    ----------
    n_units_ : tuple of int
        The N the surrogate was fitted on.
    n_outputs_ : int
    models_ : dict of int to estimator
        Fitted estimator per N (key 0: the shared model when ``per_n=False``).
    y_mean_, y_scale_ : dict of int to ndarray of shape (n_outputs,)
        Target standardisation per N, in the outputs' units.
    feature_names_, lower_, upper_, fixed_, n_train_ : dict keyed by N
        Features, training box, variables fixed in training, training rows.
    outputs_ : tuple of str or None
        Names of the outputs (the columns of ``y`` when it was a DataFrame; None otherwise).
    fit_notes_ : list of str
        Convergence warnings of the estimators (e.g. an MLP stopped at ``max_iter``).
    """

    def __init__(
        self,
        *,
        kind: str = "mlp",
        per_n: bool = True,
        params: Mapping[str, Any] | None = None,
        max_train: int | None = None,
        random_state: int = 0,
        constants: Mapping[str, Any] | None = None,
    ) -> None:
        self.kind = kind
        self.per_n = per_n
        self.params = params
        self.max_train = max_train
        self.random_state = random_state
        self.constants = constants

    def fit(self, X: pd.DataFrame, y: ArrayLike2D) -> DesignSurrogate:
        """Fit on design rows ``X`` and their outputs ``y`` (shape (n_rows, n_outputs)).

        Raises
        ------
        ValueError
            For an unknown kind, rows and outputs of different lengths, or non-finite values.
        """
        if self.kind not in KINDS:
            raise ValueError(f"kind = {self.kind!r}: choose one of {', '.join(KINDS)}")
        self.outputs_ = tuple(str(c) for c in y.columns) if isinstance(y, pd.DataFrame) else None
        y = np.asarray(y, dtype=float)
        y = y[:, None] if y.ndim == 1 else y
        if y.shape[0] != len(X):
            raise ValueError(f"y: {y.shape[0]} rows for {len(X)} design rows")
        if not np.all(np.isfinite(y)):
            raise ValueError("y: non-finite outputs (fit on rows whose outputs exist)")
        scaled = self._fit_features(X)
        n_units = X["n_units"].to_numpy(dtype=np.int64)
        self.n_outputs_ = y.shape[1]
        self.y_mean_, self.y_scale_ = {}, {}
        targets = {}
        for n in self.n_units_:
            yn = y[n_units == n]
            self.y_mean_[n] = yn.mean(axis=0)
            self.y_scale_[n] = np.where(yn.std(axis=0) > 0, yn.std(axis=0), 1.0)
            targets[n] = (yn - self.y_mean_[n]) / self.y_scale_[n]
        rng = np.random.default_rng(self.random_state)
        limit = self.max_train or (GP_MAX_TRAIN if self.kind == "gp" else None)
        self.models_ = {}
        self.fit_notes_: list[str] = []
        if self.per_n:
            for n in self.n_units_:
                self.models_[n] = self._fit_one(scaled[n], targets[n], limit, rng, n)
        else:
            Z = self._shared_matrix(scaled)
            T = np.vstack([targets[n] for n in scaled])
            self.models_[0] = self._fit_one(Z, T, limit, rng, 0)
        return self

    def _fit_one(self, Z: NDArray, T: NDArray, limit: int | None, rng, n: int) -> Any:
        if limit is not None and Z.shape[0] > limit:
            keep = np.sort(rng.choice(Z.shape[0], size=limit, replace=False))
            Z, T = Z[keep], T[keep]
        params = dict(self.params or {})
        if self.kind == "gp" and "kernel" not in params:
            from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

            params["kernel"] = ConstantKernel(1.0, (1e-2, 1e3)) * RBF(
                np.ones(Z.shape[1]), (1e-2, 1e3)
            ) + WhiteKernel(1e-4, (1e-10, 1e-1))
        model = _make_estimator(self.kind, "regress", params, self.random_state, Z.shape[0])
        target = T[:, 0] if T.shape[1] == 1 and self.kind != "gbt" else T
        return _fit_quietly(model, Z, target, self.fit_notes_, n)

    def predict(self, X: pd.DataFrame) -> NDArray:
        """Predicted outputs, shape (n_rows, n_outputs); NaN for an N not fitted.

        Rows outside the training box get a prediction too: check :meth:`in_range`.
        """
        n_units, scaled, _ = self._features(X)
        out = np.full((len(X), self.n_outputs_), np.nan)
        if not scaled:
            return out
        if self.per_n:
            for n, z in scaled.items():
                out[n_units == n] = self._unscale(self.models_[n].predict(z), n)
        else:
            Z = self._shared_matrix(scaled)
            pred = self.models_[0].predict(Z).reshape(Z.shape[0], -1)
            start = 0
            for n, z in scaled.items():
                out[n_units == n] = self._unscale(pred[start : start + z.shape[0]], n)
                start += z.shape[0]
        return out

    def _unscale(self, pred: NDArray, n: int) -> NDArray:
        return pred.reshape(pred.shape[0], -1) * self.y_scale_[n] + self.y_mean_[n]


class StatusClassifier(ClassifierMixin, _DesignModel):
    """Whether the requested state exists (``True``: status ok) from the design parameters.

    Parameters
    ----------
    kind : {"gbt", "mlp"}
    per_n : bool
        One classifier per N (True) or one for all with N as a feature.
    params : dict, optional
        Keyword arguments for the scikit-learn estimator, over this module's defaults.
    random_state : int
    constants : dict, optional
        The rows' constants set, as in :class:`DesignSurrogate`.

    Attributes
    ----------
    classes_ : ndarray ``[False, True]``
    models_ : dict of int to estimator or bool
        Fitted classifier per N (key 0 when shared); a bool where the training rows of that N
        all had one class.
    n_units_, feature_names_, lower_, upper_, fixed_, n_train_
        As in :class:`DesignSurrogate`.
    """

    def __init__(
        self,
        *,
        kind: str = "gbt",
        per_n: bool = True,
        params: Mapping[str, Any] | None = None,
        random_state: int = 0,
        constants: Mapping[str, Any] | None = None,
    ) -> None:
        self.kind = kind
        self.per_n = per_n
        self.params = params
        self.random_state = random_state
        self.constants = constants

    def fit(self, X: pd.DataFrame, y: Sequence[bool]) -> StatusClassifier:
        """Fit on design rows and whether each row's requested state exists."""
        if self.kind not in CLASSIFIER_KINDS:
            raise ValueError(f"kind = {self.kind!r}: choose one of {', '.join(CLASSIFIER_KINDS)}")
        y = np.asarray(y, dtype=bool)
        if y.shape != (len(X),):
            raise ValueError(f"y: need one bool per design row, got shape {y.shape}")
        scaled = self._fit_features(X)
        n_units = X["n_units"].to_numpy(dtype=np.int64)
        self.classes_ = np.array([False, True])
        self.models_ = {}
        self.fit_notes_: list[str] = []
        if self.per_n:
            for n in self.n_units_:
                self.models_[n] = self._fit_one(scaled[n], y[n_units == n], n)
        else:
            Z = self._shared_matrix(scaled)
            labels = np.concatenate([y[n_units == n] for n in scaled])
            self.models_[0] = self._fit_one(Z, labels, 0)
        return self

    def _fit_one(self, Z: NDArray, labels: NDArray, n: int) -> Any:
        if labels.all() or not labels.any():
            return bool(labels[0])
        model = _make_estimator(
            self.kind, "classify", self.params or {}, self.random_state, Z.shape[0]
        )
        return _fit_quietly(model, Z, labels, self.fit_notes_, n)

    def predict_proba(self, X: pd.DataFrame) -> NDArray:
        """Probabilities of ``[collapsed, ok]`` per row, shape (n_rows, 2); NaN for unknown N."""
        n_units, scaled, _ = self._features(X)
        p_ok = np.full(len(X), np.nan)
        if self.per_n:
            for n, z in scaled.items():
                p_ok[n_units == n] = self._p_ok(self.models_[n], z)
        elif scaled:
            Z = self._shared_matrix(scaled)
            p = self._p_ok(self.models_[0], Z)
            start = 0
            for n, z in scaled.items():
                p_ok[n_units == n] = p[start : start + z.shape[0]]
                start += z.shape[0]
        return np.column_stack([1.0 - p_ok, p_ok])

    @staticmethod
    def _p_ok(model: Any, z: NDArray) -> NDArray:
        if isinstance(model, bool):
            return np.full(z.shape[0], float(model))
        return model.predict_proba(z)[:, list(model.classes_).index(True)]

    def predict(self, X: pd.DataFrame) -> NDArray[np.bool_]:
        """Whether each row's requested state exists (False also for an N not fitted)."""
        return self.predict_proba(X)[:, 1] > 0.5
