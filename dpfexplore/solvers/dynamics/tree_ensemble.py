"""Regression-tree ensembles as flat arrays, proved well formed before the kernel walks them.

A :class:`TreeEnsemble` is what :func:`dpfexplore._kernels.reset.trees.tree_ensemble_predict`
evaluates: node ``i`` tests ``x[feature[i]] <= threshold[i]`` and goes to ``left[i]`` or
``right[i]``; a leaf has ``left[i] == right[i] == -1`` and contributes ``value[i]``; ``roots``
holds each tree's first node. The kernel trusts its arrays (no bounds checks, no cycle guard:
it is the fast reset model's inner loop), so every ensemble is checked whole when it is made,
in NumPy, in time linear in the nodes (:func:`check_trees`):

* tree ``t`` owns the nodes ``roots[t] .. roots[t + 1] - 1`` (``roots[0] = 0``, increasing, the
  last tree ending at the last node);
* a node is a leaf (both children ``-1``) or has two children inside its own tree with larger
  indices than its own; every node but a root is the child of exactly one node, a root of none.
  Following parents then always ends at the tree's root, so every node is reached from its
  root exactly once, every walk ends at a leaf within the tree's size, and no walk leaves the
  arrays;
* every ``feature`` lies in ``0 .. n_features - 1`` and :meth:`TreeEnsemble.predict` refuses
  inputs of another width;
* thresholds, values and the bias are finite, and the ensemble's reachable outputs
  (:attr:`TreeEnsemble.output_range`: the bias plus each tree's smallest or largest leaf) lie
  within the range its file records (:meth:`TreeEnsemble.from_dict`).

The arrays are private copies, so a caller's later change to its own arrays cannot reach them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._kernels.records import TreeArrays
from ..._kernels.reset.trees import tree_ensemble_predict

__all__ = ["TreeEnsemble", "TreeError", "check_trees", "finite_number"]

_INT_KEYS = ("feature", "left", "right", "roots")
_FLOAT_KEYS = ("threshold", "value")


class TreeError(ValueError):
    """Arrays that do not form a well-formed ensemble (one line naming the array and node)."""


@dataclass(frozen=True)
class TreeEnsemble:
    """A sum of regression trees in flat arrays (module docstring), checked on construction.

    Attributes
    ----------
    feature, left, right : ndarray of int64, shape (n_nodes,)
    threshold, value : ndarray of float64, shape (n_nodes,)
    roots : ndarray of int64, shape (n_trees,)
    bias : float
    n_features : int
        Width of the input rows: every ``feature`` lies below it.

    Raises
    ------
    TreeError
        On construction, for arrays that are not a well-formed ensemble (module docstring).
    """

    feature: NDArray[np.int64]
    threshold: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    value: NDArray[np.float64]
    roots: NDArray[np.int64]
    bias: float
    n_features: int

    def __post_init__(self) -> None:
        for key in (*_INT_KEYS, *_FLOAT_KEYS):
            kind = np.int64 if key in _INT_KEYS else np.float64
            array = np.array(getattr(self, key), dtype=kind, copy=True, order="C")
            object.__setattr__(self, key, array)
        object.__setattr__(self, "bias", float(self.bias))
        object.__setattr__(self, "n_features", int(self.n_features))
        check_trees(self)

    @property
    def output_range(self) -> tuple[float, float]:
        """The smallest and largest output any input can give (bias plus extreme leaves)."""
        leaf = self.left < 0
        tree = np.repeat(np.arange(self.roots.size), np.diff(np.append(self.roots, self.left.size)))
        low = np.full(self.roots.size, np.inf)
        high = np.full(self.roots.size, -np.inf)
        np.minimum.at(low, tree[leaf], self.value[leaf])
        np.maximum.at(high, tree[leaf], self.value[leaf])
        return float(self.bias + low.sum()), float(self.bias + high.sum())

    def predict(self, x: NDArray) -> NDArray[np.float64]:
        """Sum over the trees for each row of ``x`` (shape ``(n_rows, n_features)``).

        Raises
        ------
        ValueError
            For ``x`` of another width than :attr:`n_features`.
        """
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_features:
            raise ValueError(f"x: shape {x.shape}, need (n_rows, {self.n_features})")
        out = np.empty(x.shape[0])
        trees = TreeArrays(
            self.feature, self.threshold, self.left, self.right, self.value, self.roots, self.bias
        )
        tree_ensemble_predict(x, trees, out)
        return out

    @classmethod
    def from_gradient_boosting(cls, estimator) -> TreeEnsemble:
        """Flatten a fitted ``sklearn.ensemble.GradientBoostingRegressor`` (single output).

        Uses only its public attributes: ``estimators_[i, 0].tree_`` (``feature``,
        ``threshold``, ``children_left``/``right``, ``value``), ``learning_rate``, ``init_``
        (the initial estimate, a constant) and ``n_features_in_``.
        """
        trees = [est[0].tree_ for est in estimator.estimators_]
        rate = float(estimator.learning_rate)
        feature, threshold, left, right, value, roots = [], [], [], [], [], []
        offset = 0
        for tree in trees:
            roots.append(offset)
            leaf = tree.children_left < 0
            feature.append(np.where(leaf, 0, tree.feature))
            threshold.append(np.where(leaf, 0.0, tree.threshold))
            left.append(np.where(leaf, -1, tree.children_left + offset))
            right.append(np.where(leaf, -1, tree.children_right + offset))
            value.append(np.where(leaf, rate * tree.value[:, 0, 0], 0.0))
            offset += tree.node_count
        bias = float(np.ravel(estimator.init_.predict(np.zeros((1, estimator.n_features_in_))))[0])
        return cls(
            np.concatenate(feature).astype(np.int64),
            np.concatenate(threshold),
            np.concatenate(left).astype(np.int64),
            np.concatenate(right).astype(np.int64),
            np.concatenate(value),
            np.array(roots, dtype=np.int64),
            bias,
            int(estimator.n_features_in_),
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form, with :attr:`output_range` recorded as ``range``."""
        return {
            "feature": self.feature.tolist(),
            "threshold": self.threshold.tolist(),
            "left": self.left.tolist(),
            "right": self.right.tolist(),
            "value": self.value.tolist(),
            "roots": self.roots.tolist(),
            "bias": self.bias,
            "n_features": self.n_features,
            "range": list(self.output_range),
        }

    @classmethod
    def from_dict(cls, data: Any, *, limit: float = math.inf) -> TreeEnsemble:
        """Inverse of :meth:`to_dict`, every entry checked (module docstring).

        Parameters
        ----------
        data : dict
            As :meth:`to_dict` writes it (JSON types: integers for indices, numbers for values).
        limit : float
            The recorded ``range`` must lie within ``[-limit, limit]``.

        Raises
        ------
        TreeError
            Naming the entry (and node) that does not fit.
        """
        if not isinstance(data, dict):
            raise TreeError(f"need a table of arrays, got {type(data).__name__}")
        missing = [
            k for k in (*_INT_KEYS, *_FLOAT_KEYS, "bias", "n_features", "range") if k not in data
        ]
        if missing:
            raise TreeError(f"{missing[0]}: missing")
        arrays = {key: _int_array(data[key], key) for key in _INT_KEYS}
        arrays.update({key: _float_array(data[key], key) for key in _FLOAT_KEYS})
        bias = _finite(data["bias"], "bias")
        n_features = data["n_features"]
        if type(n_features) is not int or not 1 <= n_features <= 10_000:
            raise TreeError(f"n_features = {n_features!r}: need a whole number from 1 to 10000")
        recorded = data["range"]
        if not (isinstance(recorded, list) and len(recorded) == 2):
            raise TreeError(f"range = {recorded!r}: need [low, high]")
        low, high = (_finite(v, "range") for v in recorded)
        if not -limit <= low <= high <= limit:
            raise TreeError(f"range = [{low!r}, {high!r}]: need low <= high within ±{limit:g}")
        ensemble = cls(**arrays, bias=bias, n_features=n_features)
        reach = ensemble.output_range
        if not low <= reach[0] <= reach[1] <= high:
            raise TreeError(
                f"outputs reach [{reach[0]:.6g}, {reach[1]:.6g}] (bias and leaves), outside the "
                f"recorded range [{low:.6g}, {high:.6g}]"
            )
        return ensemble


def _int_array(values: Any, key: str) -> NDArray[np.int64]:
    if not isinstance(values, list):
        raise TreeError(f"{key}: need a list of integers, got {type(values).__name__}")
    for i, v in enumerate(values):
        if type(v) is not int or not -(2**62) < v < 2**62:
            raise TreeError(f"{key}[{i}] = {v!r}: need an integer node or feature index")
    return np.array(values, dtype=np.int64)


def _float_array(values: Any, key: str) -> NDArray[np.float64]:
    if not isinstance(values, list):
        raise TreeError(f"{key}: need a list of numbers, got {type(values).__name__}")
    for i, v in enumerate(values):
        _finite(v, f"{key}[{i}]")
    return np.array(values, dtype=np.float64)


def finite_number(value: Any, key: str, error: type[ValueError] = ValueError) -> float:
    """``value`` of a JSON file as a finite float; ``error`` naming ``key`` otherwise.

    Only an int or a float is a number here (not a bool, a string or None); an int beyond a
    float's range is not finite.
    """
    if type(value) not in (int, float):
        raise error(f"{key} = {value!r}: need a number")
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise error(f"{key} = {value!r}: need a finite number")
    return number


def _finite(value: Any, key: str) -> float:
    return finite_number(value, key, TreeError)


def check_trees(trees: TreeEnsemble) -> None:
    """Raise :class:`TreeError` unless ``trees`` is a well-formed ensemble (module docstring)."""
    feature, left, right, roots = trees.feature, trees.left, trees.right, trees.roots
    n = feature.size
    for key in ("feature", "threshold", "left", "right", "value", "roots"):
        if getattr(trees, key).ndim != 1:
            raise TreeError(f"{key}: need a flat array")
    for key in ("threshold", "left", "right", "value"):
        if getattr(trees, key).size != n:
            raise TreeError(f"{key}: {getattr(trees, key).size} entries for {n} nodes")
    if n == 0 or roots.size == 0:
        raise TreeError("no nodes or no trees")
    if roots[0] != 0 or np.any(np.diff(roots) <= 0) or roots[-1] >= n:
        raise TreeError(
            f"roots: need 0 first, then increasing node indices below {n} (one tree each)"
        )
    for key in ("threshold", "value"):
        bad = ~np.isfinite(getattr(trees, key))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TreeError(f"{key}[{i}] = {getattr(trees, key)[i]!r}: need a finite number")
    if not math.isfinite(trees.bias):
        raise TreeError(f"bias = {trees.bias!r}: need a finite number")
    bad = (feature < 0) | (feature >= trees.n_features)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TreeError(
            f"feature[{i}] = {feature[i]}: outside the {trees.n_features} input features"
        )
    ends = np.append(roots[1:], n)
    tree = np.repeat(np.arange(roots.size), ends - roots)
    node = np.arange(n)
    for key, child in (("left", left), ("right", right)):
        bad = (child != -1) & ((child <= node) | (child >= ends[tree]))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TreeError(
                f"{key}[{i}] = {child[i]}: outside the nodes {i + 1} .. {ends[tree[i]] - 1} "
                "after it in its tree (or -1 for a leaf)"
            )
    leaf = (left == -1) & (right == -1)
    half = (left == -1) ^ (right == -1)
    if half.any():
        i = int(np.flatnonzero(half)[0])
        raise TreeError(
            f"node {i}: left = {left[i]}, right = {right[i]}: a node has two children or none "
            "(a leaf has left = right = -1)"
        )
    inner = ~leaf
    parents = np.bincount(np.concatenate([left[inner], right[inner]]), minlength=n)
    is_root = np.zeros(n, dtype=bool)
    is_root[roots] = True
    bad = parents != np.where(is_root, 0, 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TreeError(
            f"node {i} is the child of {parents[i]} nodes, need {0 if is_root[i] else 1} "
            "(every node is reached from its tree's root exactly once)"
        )
