"""Evaluation of a fitted ensemble of regression trees stored as flat arrays.

A fitted model is saved as plain arrays (JSON), never as a pickle: node ``i`` of the ensemble
tests ``x[feature[i]] <= threshold[i]`` and goes to ``left[i]`` or ``right[i]``; a leaf has
``left[i] == -1`` and contributes ``value[i]``; ``roots`` holds each tree's first node. The
trees of scikit-learn compare the inputs as float32 against float64 thresholds, so the inputs
are rounded to float32 here too and predictions match the estimator's exactly.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel


@kernel
def tree_ensemble_predict(x, trees, out):
    """``out[r] = bias + Σ_trees value(leaf reached by row r)``.

    Parameters
    ----------
    x : ndarray of shape (n_rows, n_features)
    trees : TreeArrays
        The ensemble (:mod:`.records`): ``feature``, ``left``, ``right`` (int64) and
        ``threshold``, ``value`` of shape (n_nodes,), ``roots`` (int64, (n_trees,)), ``bias``.
    out : ndarray of shape (n_rows,)
    """
    feature, threshold, left, right, value, roots, bias = trees
    for r in range(x.shape[0]):
        total = bias
        for t in range(roots.shape[0]):
            node = roots[t]
            while left[node] >= 0:
                if np.float32(x[r, feature[node]]) <= threshold[node]:
                    node = left[node]
                else:
                    node = right[node]
            total += value[node]
        out[r] = total
