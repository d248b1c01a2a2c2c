"""The chain surrogate: per-unit quantities learned from local inputs, composed exactly.

A flat surrogate learns the whole finger at once, and its error grows with N. The chain
surrogate uses the finger's structure (:mod:`dpfexplore.surrogates.chain_physics`): a shape is
three numbers per unit (the turn ``rho_k`` of post ``k``, the heading ``beta_k`` of its layer
segment relative to post ``k - 1``, the segment length ``ell_k``), and the tip, bend angle and
curvature follow from them by exact kinematics. Each unit's three numbers depend, to ~1e-7 rad,
only on that unit, the unit before it and whether it is the first or second unit.

:class:`ChainSurrogate`
    Per unit, the rigid unit-cell model gives ``rho`` and ``beta`` to a few 1e-4 rad; a
    scikit-learn regressor (an MLP by default) learns what it leaves out (the stretch of posts
    and layer): ``rho - rho_rigid``, ``beta - beta_rigid`` and the layer strain
    ``ell / p - 1``, from the unit's and its predecessor's parameters, closed forms (MODEL.md
    §3-§4) and rigid solutions, its position (first, second, later) and requested side. One
    regressor serves every unit of every N: its training rows are units (~4.5 per design in the
    paper's box). Fitting recomputes the training designs' exact shapes with
    :func:`dpfexplore.solve_batch` (the sweep stores no shapes) and checks them against the
    given tip. Outputs other than the chain's geometric ones (:data:`GEOMETRIC_OUTPUTS`, e.g.
    the stiffness) are left to a flat :class:`~dpfexplore.surrogates.flat.DesignSurrogate`
    (``inner``).

:class:`ChainStatusClassifier`
    The requested state exists when every unit holds on its requested side: the smallest
    holding margin of the rigid unit-cell model over the inverted units is positive (no fitted
    threshold: on the paper's box a learned shift of it lost accuracy, the exact boundary being
    fuzzy on the margin's scale of 1e-5). A logistic slope fitted on the training designs turns
    the margin into a probability. It knows nothing of states that collapse because a *flat*
    unit cannot stay flat between inverted neighbours.

Range: both flag (:meth:`in_range`) a design whose N was not among the training designs', whose
unit or shared variables lie outside the training ranges (pooled over units), or whose requested
side of some unit was never seen in training. They still predict any N (units beyond the
training N are interior units like the others), but such a prediction is flagged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, ClassifierMixin, RegressorMixin

from ..model import status as st
from ..model.design import PER_UNIT_FIELDS, SHARED_FIELDS, DesignBatch
from ..model.domain import MAX_UNITS
from ..solvers.statics import solve_batch
from .chain_physics import (
    GEOMETRIC_OUTPUTS,
    RigidUnits,
    compose,
    rigid_units,
    state_bits,
    unit_kinematics,
)
from .data import designs_from_rows
from .flat import RANGE_SLACK, DesignSurrogate, _fit_quietly, constants_set_of

__all__ = ["CHAIN", "ChainStatusClassifier", "ChainSurrogate", "feature_names", "unit_rows"]

#: Kind name of the chain surrogate and classifier in reports.
CHAIN = "chain"
#: Features of a unit (its own and, in a row, its predecessor's).
UNIT_FEATURES = (
    "H",
    "U_L",
    "U_sep",
    "alpha",
    "reach",
    "inverted_extension",
    "rho_rigid",
    "beta_rigid",
    "k_b_over_k_t",
    "k_lim_over_k_t",
    "p",
    "inverted",
    "margin",
)
#: Features shared by a design's units.
SHARED_FEATURES = ("t", "t_lim", "h")
#: Learned per-unit targets.
TARGETS = ("rho_residual", "beta_residual", "strain")
#: Largest |margin| used as a feature (units far from the fold are alike).
MARGIN_CLIP = 0.05
#: Scale of the margin in the status probability (the exact boundary's fuzz, ~1e-5..1e-4).
MARGIN_SCALE = 1e-4
#: Tolerance of the tip recomputed at fit time against the training outputs (mm).
TIP_CHECK_MM = 1e-6


def _check_frame(X: Any) -> pd.DataFrame:
    if not isinstance(X, pd.DataFrame):
        raise ValueError(f"X: need a pandas DataFrame of design rows, got {type(X).__name__}")
    needed = ["n_units", *SHARED_FIELDS, *(f"{name}_1" for name in PER_UNIT_FIELDS)]
    missing = [c for c in needed if c not in X.columns]
    if missing:
        raise ValueError(f"X: missing column {missing[0]!r}")
    return X


def _designs(
    X: pd.DataFrame, all_inverted_only: bool | None, constants: Mapping[str, Any] | None
) -> tuple[DesignBatch, NDArray]:
    """Batch and requested sides (n, MAX_UNITS) of design rows.

    Without a ``requested`` column the state is all-inverted, allowed only when the model was
    fitted on that state alone (``all_inverted_only``; None at fit time). The batch runs on the
    estimator's constants set (``constants``, its JSON form; None: the paper's).
    """
    X = _check_frame(X)
    n_units = X["n_units"].to_numpy(dtype=np.int64)
    largest = int(np.clip(n_units.max(initial=0), 0, MAX_UNITS))
    for name in PER_UNIT_FIELDS:
        if f"{name}_{largest}" not in X.columns:
            raise ValueError(f"X: missing column '{name}_{largest}' (N = {largest})")
    if "requested" in X.columns:
        requested = X["requested"].to_numpy(dtype=np.int64)
    elif all_inverted_only is False:
        raise ValueError(
            "X: missing column 'requested' (the model was fitted on several requested states)"
        )
    else:
        requested = (np.int64(1) << np.clip(n_units, 0, MAX_UNITS)) - 1
    return designs_from_rows(X, constants_set_of(constants)), state_bits(requested, n_units)


def unit_rows(rigid: RigidUnits) -> NDArray:
    """Feature rows of every unit of a batch, in the order of ``rigid``'s units.

    Returns
    -------
    ndarray of shape (m, 2 len(UNIT_FEATURES) + len(SHARED_FEATURES) + 2)
        The unit's :data:`UNIT_FEATURES`, its predecessor's (zeros for unit 1),
        :data:`SHARED_FEATURES`, and whether it is unit 1, unit 2.
    """
    h = rigid.h
    with np.errstate(invalid="ignore", divide="ignore"):
        own = np.column_stack(
            [
                rigid.H,
                rigid.U_L,
                rigid.U_sep,
                rigid.alpha,
                rigid.d,
                rigid.u_second * rigid.d,
                rigid.rho,
                rigid.beta,
                rigid.k_b * h * h / rigid.k_t,
                rigid.k_lim * h * h / rigid.k_t,
                rigid.p,
                rigid.inverted.astype(float),
                np.clip(rigid.margin, -MARGIN_CLIP, MARGIN_CLIP),
            ]
        )
    first = rigid.unit == 0
    # The units of a design are consecutive, unit 1 first: the predecessor is the row before.
    previous = np.where(first[:, None], 0.0, np.roll(own, 1, axis=0))
    return np.column_stack([own, previous, rigid.t, rigid.t_lim, h, first, rigid.unit == 1]).astype(
        float
    )


def feature_names() -> list[str]:
    """Names of the columns of :func:`unit_rows`' features."""
    return [
        *UNIT_FEATURES,
        *(f"previous_{name}" for name in UNIT_FEATURES),
        *SHARED_FEATURES,
        "unit_1",
        "unit_2",
    ]


class _UnitBox(BaseEstimator):
    """The training box of unit-level design variables (fitted attributes end in ``_``)."""

    def _fit_box(self, batch: DesignBatch, bits: NDArray) -> None:
        n_units = batch.n_units
        active = np.arange(MAX_UNITS)[None, :] < n_units[:, None]
        self.n_units_ = tuple(int(n) for n in np.unique(n_units))
        self.unit_lower_ = {
            name: float(np.min(getattr(batch, name)[active])) for name in PER_UNIT_FIELDS
        }
        self.unit_upper_ = {
            name: float(np.max(getattr(batch, name)[active])) for name in PER_UNIT_FIELDS
        }
        self.shared_lower_ = {name: float(np.min(getattr(batch, name))) for name in SHARED_FIELDS}
        self.shared_upper_ = {name: float(np.max(getattr(batch, name))) for name in SHARED_FIELDS}
        self.sides_ = tuple(sorted({int(v) for v in bits[active]}))
        self.all_inverted_only_ = self.sides_ == (1,)
        self.n_train_ = {n: int(np.sum(n_units == n)) for n in self.n_units_}

    def _inside(self, batch: DesignBatch, bits: NDArray) -> NDArray[np.bool_]:
        n_units = batch.n_units
        active = np.arange(MAX_UNITS)[None, :] < np.clip(n_units, 0, MAX_UNITS)[:, None]

        def within(values, lo, hi):
            slack = RANGE_SLACK * max(1.0, abs(lo), abs(hi))
            return (values >= lo - slack) & (values <= hi + slack)

        ok = np.isin(n_units, self.n_units_)
        for name in PER_UNIT_FIELDS:
            values = getattr(batch, name)
            inside = within(values, self.unit_lower_[name], self.unit_upper_[name])
            ok &= np.all(inside | ~active, axis=1)
        for name in SHARED_FIELDS:
            ok &= within(getattr(batch, name), self.shared_lower_[name], self.shared_upper_[name])
        seen = np.isin(bits.astype(int), self.sides_)
        ok &= np.all(seen | ~active, axis=1)
        return ok

    def in_range(self, X: pd.DataFrame) -> NDArray[np.bool_]:
        """Whether each row lies in the box the model was fitted on (else: do not trust it).

        Returns
        -------
        ndarray of bool, shape (n_rows,)
            False for an N not among the training designs', a unit or shared variable outside
            its training range (unit variables pooled over units), or a requested side of a
            unit never seen in training.
        """
        batch, bits = _designs(X, self.all_inverted_only_, self.constants)
        return self._inside(batch, bits)


class ChainSurrogate(RegressorMixin, _UnitBox):
    """Chain surrogate of a finger's geometric outputs (module docstring).

    Parameters
    ----------
    outputs : sequence of str
        Names of the columns of ``y``, e.g. ``("tip_x", "tip_y", "curvature", "stiffness")``.
        :data:`GEOMETRIC_OUTPUTS` are composed; others go to the ``inner`` surrogate.
    params : dict, optional
        Keyword arguments of the per-unit ``MLPRegressor``, over this class's defaults
        (two hidden layers of 32, Adam, batches of 1024, at most 100 epochs).
    inner : str
        Kind of the flat :class:`DesignSurrogate` of the other outputs.
    inner_params : dict, optional
        Its estimator keyword arguments.
    max_train : int, optional
        Fit the per-unit regressor on at most this many unit rows (a random subsample).
    random_state : int
    constants : dict, optional
        The constants set the rigid units are solved under, as its JSON form
        (:meth:`~dpfexplore.model.constants_set.ConstantsSet.to_dict`; verified when used);
        None for the paper's. The training dataset's set.

    Attributes
    ----------
    model_ : MLPRegressor
        The per-unit regressor (inputs scaled to [0, 1] on the training rows).
    lower_, upper_, varying_ : ndarray
        Feature scaling (columns constant in training are dropped).
    t_mean_, t_scale_ : ndarray of shape (3,)
        Target standardisation.
    inner_model_ : DesignSurrogate or None
    n_unit_rows_ : int
        Unit rows the regressor was fitted on.
    n_units_, n_train_, unit_lower_, unit_upper_, shared_lower_, shared_upper_, sides_
        The training box (:meth:`in_range`).
    fit_notes_ : list of str
    """

    def __init__(
        self,
        *,
        outputs: Sequence[str] = ("tip_x", "tip_y"),
        params: Mapping[str, Any] | None = None,
        inner: str = "mlp",
        inner_params: Mapping[str, Any] | None = None,
        max_train: int | None = None,
        random_state: int = 0,
        constants: Mapping[str, Any] | None = None,
    ) -> None:
        self.outputs = outputs
        self.params = params
        self.inner = inner
        self.inner_params = inner_params
        self.max_train = max_train
        self.random_state = random_state
        self.constants = constants

    def fit(self, X: pd.DataFrame, y: Any) -> ChainSurrogate:
        """Fit on design rows whose requested state exists and their outputs.

        Raises
        ------
        ValueError
            For outputs and ``y`` that do not match, non-finite outputs, a row whose requested
            state the exact model does not find, or training tips that differ from the exact
            model's (data computed by another model).
        """
        outputs = list(self.outputs)
        y = np.asarray(y, dtype=float)
        y = y[:, None] if y.ndim == 1 else y
        if y.shape != (len(X), len(outputs)):
            raise ValueError(
                f"y: shape {y.shape}, need ({len(X)}, {len(outputs)}) for outputs "
                f"{', '.join(outputs)}"
            )
        if not np.all(np.isfinite(y)):
            raise ValueError("y: non-finite outputs (fit on rows whose outputs exist)")
        batch, bits = _designs(X, None, self.constants)
        if np.any(batch.status() != st.OK):
            raise ValueError("X: invalid designs among the rows (fit on valid designs)")
        self._fit_box(batch, bits)
        requested = _requested(bits, batch.n_units)
        exact = solve_batch(batch, requested, stiffness=False, min_eig=False, shapes=True)
        missing = int(np.sum(exact["status"] != st.OK))
        if missing:
            raise ValueError(
                f"X: {missing} rows whose requested state the exact model does not "
                "find (fit on rows with status ok)"
            )
        for name in ("tip_x", "tip_y"):
            if name in outputs:
                gap = float(np.max(np.abs(exact[name] - y[:, outputs.index(name)])))
                if gap > TIP_CHECK_MM:
                    raise ValueError(
                        f"y: {name} differs from the exact model's by up to "
                        f"{gap:.3g} mm (data of another model version?)"
                    )
        rigid = rigid_units(batch, bits)
        rho, beta, ell = unit_kinematics(
            exact["x"], batch.n_units, rigid.p[rigid.unit == 0], rigid.h[rigid.unit == 0]
        )
        features = unit_rows(rigid)
        design, k0 = rigid.design, rigid.unit
        targets = np.column_stack(
            [
                rho[design, k0] - rigid.rho,
                beta[design, k0] - rigid.beta,
                ell[design, k0] / rigid.p - 1.0,
            ]
        )
        # Units whose rigid model has no minimum on the requested side (a few near the fold)
        # would teach a residual of another branch.
        keep = rigid.holds & np.all(np.isfinite(targets), axis=1)
        features, targets = features[keep], targets[keep]
        rng = np.random.default_rng(self.random_state)
        if self.max_train is not None and features.shape[0] > self.max_train:
            pick = np.sort(rng.choice(features.shape[0], size=self.max_train, replace=False))
            features, targets = features[pick], targets[pick]
        self.n_unit_rows_ = int(features.shape[0])
        lo, hi = features.min(axis=0), features.max(axis=0)
        self.varying_ = hi > lo
        self.lower_, self.upper_ = lo[self.varying_], hi[self.varying_]
        self.t_mean_ = targets.mean(axis=0)
        self.t_scale_ = np.where(targets.std(axis=0) > 0, targets.std(axis=0), 1.0)
        notes: list[str] = []
        self.model_ = _fit_quietly(
            self._estimator(features.shape[0]),
            self._scale(features),
            (targets - self.t_mean_) / self.t_scale_,
            notes,
            0,
        )
        self.fit_notes_ = [note.replace("N=0:", "unit model:", 1) for note in notes]
        others = [j for j, name in enumerate(outputs) if name not in GEOMETRIC_OUTPUTS]
        self.inner_model_ = None
        if others:
            self.inner_model_ = DesignSurrogate(
                kind=self.inner,
                params=self.inner_params,
                random_state=self.random_state,
                constants=self.constants,
            ).fit(X, pd.DataFrame(y[:, others], columns=[outputs[j] for j in others]))
            self.fit_notes_ += [f"inner: {note}" for note in self.inner_model_.fit_notes_]
        self.n_outputs_ = len(outputs)
        return self

    def _estimator(self, n_rows: int):
        from sklearn.neural_network import MLPRegressor

        defaults = {
            "hidden_layer_sizes": (32, 32),
            "batch_size": 1024,
            "max_iter": 100,
            "learning_rate_init": 2e-3,
            "tol": 1e-7,
            "n_iter_no_change": 20,
            "random_state": self.random_state,
        }
        merged = {**defaults, **(self.params or {})}
        merged["batch_size"] = min(merged["batch_size"], n_rows)  # sklearn warns otherwise
        return MLPRegressor(**merged)

    def _scale(self, features: NDArray) -> NDArray:
        return (features[:, self.varying_] - self.lower_) / (self.upper_ - self.lower_)

    def predict_units(self, X: pd.DataFrame) -> tuple[NDArray, NDArray, NDArray, RigidUnits]:
        """Per-unit ``rho, beta, ell`` of design rows, shapes (n, MAX_UNITS), and the rigid model.

        Values beyond a design's N are NaN.
        """
        batch, bits = _designs(X, self.all_inverted_only_, self.constants)
        rigid = rigid_units(batch, bits)
        residual = np.zeros((rigid.unit.size, len(TARGETS)))
        if rigid.unit.size:
            z = np.ascontiguousarray(np.nan_to_num(self._scale(unit_rows(rigid))))
            residual = self.model_.predict(z).reshape(-1, len(TARGETS))
            residual = residual * self.t_scale_ + self.t_mean_
        first = rigid.unit == 0
        rho = rigid.grid(rigid.rho + residual[:, 0])
        # Unit 1's layer segment is clamped: no heading, its rest length.
        beta = rigid.grid(np.where(first, 0.0, rigid.beta + residual[:, 1]))
        ell = rigid.grid(rigid.p * np.where(first, 1.0, 1.0 + residual[:, 2]))
        return rho, beta, ell, rigid

    def predict(self, X: pd.DataFrame) -> NDArray:
        """Predicted outputs, shape (n_rows, n_outputs) in the order of ``outputs``.

        Rows outside the training box get a prediction too: check :meth:`in_range`.
        """
        rho, beta, ell, rigid = self.predict_units(X)
        n_units = np.clip(X["n_units"].to_numpy(dtype=np.int64), 0, MAX_UNITS)
        h = rigid.grid(rigid.h)[:, 0]
        geometry = compose(np.nan_to_num(rho), np.nan_to_num(beta), np.nan_to_num(ell), n_units, h)
        out = np.full((len(X), len(self.outputs)), np.nan)
        others = []
        for j, name in enumerate(self.outputs):
            if name in GEOMETRIC_OUTPUTS:
                out[:, j] = geometry[name]
            else:
                others.append(j)
        if others and self.inner_model_ is not None:
            out[:, others] = self.inner_model_.predict(X)
        return out


def _requested(bits: NDArray, n_units: NDArray) -> NDArray[np.int64]:
    """State integers (unit 1 = most significant bit) of requested sides."""
    n_units = np.clip(np.asarray(n_units, dtype=np.int64), 0, MAX_UNITS)
    k = np.arange(1, MAX_UNITS + 1)[None, :]
    weights = np.where(
        k <= n_units[:, None], np.int64(1) << np.clip(n_units[:, None] - k, 0, None), 0
    )
    return (bits.astype(np.int64) * weights).sum(axis=1)


class ChainStatusClassifier(ClassifierMixin, _UnitBox):
    """Whether the requested state exists: every unit holds in the rigid unit-cell model.

    Parameters
    ----------
    C : float
        Inverse regularisation of the logistic slope that calibrates the probability.
    random_state : int
        Unused (no randomness); kept for the common interface.
    constants : dict, optional
        The constants set the rigid units are solved under, as its JSON form
        (:meth:`~dpfexplore.model.constants_set.ConstantsSet.to_dict`; verified when used);
        None for the paper's. The training dataset's set.

    Attributes
    ----------
    classes_ : ndarray ``[False, True]``
    slope_ : float
        Probability of existence ``1 / (1 + exp(-slope_ * q))``, ``q`` the smallest margin over
        :data:`MARGIN_SCALE`, clipped to [-10, 10].
    n_units_, n_train_, unit_lower_, unit_upper_, shared_lower_, shared_upper_, sides_
        The training box (:meth:`in_range`).
    fit_notes_ : list of str
    """

    def __init__(
        self, *, C: float = 1.0, random_state: int = 0, constants: Mapping[str, Any] | None = None
    ) -> None:
        self.C = C
        self.random_state = random_state
        self.constants = constants

    @property
    def kind(self) -> str:
        """``"chain"``, as the report names classifiers by kind."""
        return CHAIN

    @property
    def per_n(self) -> bool:
        """False: one rule for every N."""
        return False

    def _margin(self, X: pd.DataFrame, all_inverted_only: bool | None) -> NDArray:
        batch, bits = _designs(X, all_inverted_only, self.constants)
        rigid = rigid_units(batch, bits)
        margin = rigid.grid(rigid.margin, np.inf).min(axis=1)
        return np.clip(margin / MARGIN_SCALE, -10.0, 10.0)

    def fit(self, X: pd.DataFrame, y: Sequence[bool]) -> ChainStatusClassifier:
        """Fit the probability's slope on design rows and whether each row's state exists."""
        from sklearn.linear_model import LogisticRegression

        y = np.asarray(y, dtype=bool)
        if y.shape != (len(X),):
            raise ValueError(f"y: need one bool per design row, got shape {y.shape}")
        batch, bits = _designs(X, None, self.constants)
        self._fit_box(batch, bits)
        q = self._margin(X, None)
        self.classes_ = np.array([False, True])
        self.fit_notes_: list[str] = []
        if y.all() or not y.any():
            self.slope_ = 1.0
            self.fit_notes_.append("one class in training: slope not fitted")
        else:
            model = LogisticRegression(C=self.C, fit_intercept=False)
            self.slope_ = float(model.fit(q[:, None], y).coef_[0, 0])
            if self.slope_ <= 0.0:  # existence falling with the margin: no use as a probability
                self.fit_notes_.append(f"fitted slope {self.slope_:.3g} <= 0: set to 1")
                self.slope_ = 1.0
        return self

    def predict_proba(self, X: pd.DataFrame) -> NDArray:
        """Probabilities of ``[collapsed, ok]`` per row, shape (n_rows, 2)."""
        q = self._margin(X, self.all_inverted_only_)
        p_ok = 1.0 / (1.0 + np.exp(-self.slope_ * q))
        return np.column_stack([1.0 - p_ok, p_ok])

    def predict(self, X: pd.DataFrame) -> NDArray[np.bool_]:
        """Whether each row's requested state exists (smallest margin positive)."""
        return self._margin(X, self.all_inverted_only_) > 0.0
