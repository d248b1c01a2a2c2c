"""Closed forms selected from per-curve constants: RFE with ridge, done right (MODEL.md §11).

Targets (per curve, one per row of :data:`~dpfexplore.model.quantities.SET_FORMS`):
``k_hat = k_b R / (E t²)`` (the ``E t²/R`` scaling removed exactly), ``alpha``, and
``tip_ratio = tip_dis / H`` when the table gives ``tip_dis``. Library: the
monomials ``π1^p π3^q``, ``0 <= p, q <= degree`` (``π1 = t/H``, ``π3 = H/R``), the constant being
the intercept. The paper's library in ``π1, π2, π3`` has duplicate columns (``π2 = π1 π3``);
written by exponent vector in ``(π1, π3)`` it is exactly this tensor-product basis.

Selection, for each target:

1. features standardised inside a pipeline (``StandardScaler`` + ``Ridge``), so coefficient sizes
   are comparable when RFE ranks them;
2. :class:`~sklearn.feature_selection.RFECV` cross-validated by **geometry groups**
   (:class:`~sklearn.model_selection.GroupKFold` on ``(H, t, r_b)``): the curves of one geometry
   at several ``E`` never sit on both sides of a split, which would leak (tested);
3. the number of terms by the one-standard-error rule: the fewest terms whose mean CV score is
   within one standard error of the best;
4. an unbiased refit: ordinary least squares on the selected terms (no ridge shrinkage).

An alternative selector (:class:`~sklearn.linear_model.LassoCV` on the same groups, then the
same OLS refit) is compared on held-out geometries (30 % of the geometries, never seen by either
selection); :class:`Selection` records both scores and which won.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model.constants_set import ClosedForm

__all__ = ["SELECTORS", "Selection", "library", "monomials", "select_closed_form"]

#: The selectors :func:`select_closed_form` knows.
SELECTORS = ("rfecv", "lasso")


def library(degree: int) -> list[tuple[int, int]]:
    """Exponent pairs ``(p, q)`` of the monomials ``π1^p π3^q`` without the constant."""
    return [(p, q) for p in range(degree + 1) for q in range(degree + 1) if (p, q) != (0, 0)]


def monomials(pi1: NDArray, pi3: NDArray, exponents: list[tuple[int, int]]) -> NDArray:
    """The feature matrix: one column ``π1^p π3^q`` per exponent pair."""
    pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
    return np.column_stack([pi1**p * pi3**q for p, q in exponents])


@dataclass(frozen=True)
class Selection:
    """One target's selected closed form and how it was chosen.

    Attributes
    ----------
    form : ClosedForm
        The refitted closed form (intercept as the ``(0, 0)`` term).
    selector : str
        The selector whose support was used for ``form``.
    cv_curve : list of dict
        ``n_terms``, ``mean``, ``std`` of the grouped CV RMSE of RFECV per number of terms.
    n_terms : int
        Terms chosen by the one-standard-error rule (excluding the constant).
    heldout : dict
        Per selector, RMSE and R² on held-out geometries, and ``winner``.
    """

    form: ClosedForm
    selector: str
    cv_curve: list[dict[str, float]] = field(default_factory=list)
    n_terms: int = 0
    heldout: dict[str, Any] = field(default_factory=dict)


def _pipeline(ridge_alpha: float):
    from sklearn.linear_model import Ridge
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    return Pipeline([("scale", StandardScaler()), ("ridge", Ridge(alpha=ridge_alpha))])


def _rfecv_support(
    X: NDArray, y: NDArray, groups: NDArray, n_splits: int, ridge_alpha: float
) -> tuple[NDArray, list[dict[str, float]], int]:
    from sklearn.feature_selection import RFE, RFECV
    from sklearn.model_selection import GroupKFold

    splits = min(n_splits, len(np.unique(groups)))
    rfecv = RFECV(
        _pipeline(ridge_alpha),
        step=1,
        cv=GroupKFold(n_splits=splits),
        scoring="neg_root_mean_squared_error",
        importance_getter="named_steps.ridge.coef_",
        min_features_to_select=1,
    )
    rfecv.fit(X, y, groups=groups)
    n_features = np.asarray(rfecv.cv_results_["n_features"])
    mean = -np.asarray(rfecv.cv_results_["mean_test_score"])
    std = np.asarray(rfecv.cv_results_["std_test_score"])
    best = int(np.argmin(mean))
    limit = mean[best] + std[best] / np.sqrt(splits)
    chosen = int(n_features[np.flatnonzero(mean <= limit).min()])
    curve = [
        {"n_terms": int(n), "rmse": float(m), "std": float(s)}
        for n, m, s in zip(n_features, mean, std, strict=True)
    ]
    rfe = RFE(
        _pipeline(ridge_alpha),
        n_features_to_select=chosen,
        step=1,
        importance_getter="named_steps.ridge.coef_",
    ).fit(X, y)
    return rfe.support_, curve, chosen


def _lasso_support(X: NDArray, y: NDArray, groups: NDArray, n_splits: int, seed: int) -> NDArray:
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.linear_model import LassoCV
    from sklearn.model_selection import GroupKFold
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    splits = list(GroupKFold(n_splits=min(n_splits, len(np.unique(groups)))).split(X, y, groups))
    model = Pipeline([("scale", StandardScaler()), ("lasso", LassoCV(cv=splits, max_iter=100_000))])
    with warnings.catch_warnings():
        # the weakest penalties of the path converge slowly on collinear monomials; the support
        # is read at the CV optimum, far from them
        warnings.simplefilter("ignore", ConvergenceWarning)
        model.fit(X, y)
    support = np.abs(model.named_steps["lasso"].coef_) > 0
    if not support.any():
        support[np.argmax(np.abs(np.corrcoef(X.T, y)[-1, :-1]))] = True
    return support


def _refit(X: NDArray, y: NDArray, support: NDArray) -> tuple[float, NDArray]:
    """OLS with intercept on the selected columns: ``(intercept, coefficients)``."""
    A = np.column_stack([np.ones(len(y)), X[:, support]])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(coef[0]), coef[1:]


def _form(exponents: list[tuple[int, int]], support: NDArray, intercept: float, coef) -> ClosedForm:
    chosen = [e for e, keep in zip(exponents, support, strict=True) if keep]
    return ClosedForm(((0, 0), *chosen), (intercept, *(float(c) for c in coef)))


def _support(selector, X, y, groups, n_splits, ridge_alpha, seed):
    if selector == "rfecv":
        return _rfecv_support(X, y, groups, n_splits, ridge_alpha)
    return _lasso_support(X, y, groups, n_splits, seed), [], 0


def select_closed_form(
    pi1: NDArray,
    pi3: NDArray,
    y: NDArray,
    groups: NDArray,
    *,
    degree: int = 3,
    selector: str = "rfecv",
    n_splits: int = 5,
    ridge_alpha: float = 1e-6,
    heldout_fraction: float = 0.3,
    seed: int = 0,
) -> Selection:
    """Select and refit the closed form of one target (module docstring).

    Parameters
    ----------
    pi1, pi3 : ndarray
        ``t/H`` and ``H/R`` per curve.
    y : ndarray
        The target per curve.
    groups : ndarray
        Geometry label per curve: curves of one geometry are never split apart.
    selector : {"rfecv", "lasso"}
        Whose support the returned form uses; both are scored on held-out geometries.
    """
    from sklearn.model_selection import GroupShuffleSplit

    if selector not in SELECTORS:
        raise ValueError(f"selector = {selector!r}: choose one of {', '.join(SELECTORS)}")
    exponents = library(degree)
    X = monomials(pi1, pi3, exponents)
    y = np.asarray(y, dtype=float)
    groups = np.asarray(groups)
    heldout: dict[str, Any] = {}
    if len(np.unique(groups)) >= 2 * n_splits:
        split = GroupShuffleSplit(n_splits=1, test_size=heldout_fraction, random_state=seed)
        train, test = next(split.split(X, y, groups))
        for name in SELECTORS:
            support, _, _ = _support(
                name, X[train], y[train], groups[train], n_splits, ridge_alpha, seed
            )
            intercept, coef = _refit(X[train], y[train], support)
            predicted = intercept + X[test][:, support] @ coef
            residual = predicted - y[test]
            total = float(np.sum((y[test] - y[test].mean()) ** 2)) or 1.0
            heldout[name] = {
                "rmse": float(np.sqrt(np.mean(residual**2))),
                "r2": 1.0 - float(residual @ residual) / total,
                "terms": int(support.sum()) + 1,
            }
        heldout["winner"] = min(SELECTORS, key=lambda name: heldout[name]["rmse"])
        heldout["geometries"] = {
            "train": len(np.unique(groups[train])),
            "test": len(np.unique(groups[test])),
        }
    support, curve, n_terms = _support(selector, X, y, groups, n_splits, ridge_alpha, seed)
    intercept, coef = _refit(X, y, support)
    return Selection(
        form=_form(exponents, support, intercept, coef),
        selector=selector,
        cv_curve=curve,
        n_terms=n_terms or int(support.sum()),
        heldout=heldout,
    )
