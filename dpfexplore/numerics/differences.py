"""Central differences of a batch function, clipped to bounds, one-sided where a side fails.

The one finite-difference Jacobian of the package: inverse design's fallback where exact
sensitivities are undefined (:mod:`dpfexplore.inverse.engine.derivatives`), lookup's central
polish (:mod:`dpfexplore.lookup.polish`) and the sensitivity benchmark's baseline
(:mod:`dpfexplore.bench.sensitivities`).

``func`` takes a batch of points (one per row) and returns one row of outputs per point, NaN
where the output does not exist there (a state that collapses next to a fold). Every displaced
point is evaluated in one call of ``func``. A displacement that would leave ``[lower, upper]`` is
clipped to the bounds; a pair with one side missing falls back to the one-sided difference from
the centre; a variable with both sides missing gets a zero column (the caller cannot move along
it). With ``richardson`` each derivative is also taken at half the step and the two combined,
``(4 D(h/2) - D(h)) / 3``, which cancels the ``h²`` error term of smooth functions.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["central_differences"]


def _one_step(
    func: Callable[[NDArray], NDArray],
    x: NDArray,
    f0: NDArray,
    cols: NDArray,
    step: NDArray,
    lower: NDArray,
    upper: NDArray,
) -> NDArray:
    k = cols.size
    up = np.repeat(x[None, :], k, axis=0)
    down = up.copy()
    idx = np.arange(k)
    up[idx, cols] = np.minimum(x[cols] + step[cols], upper[cols])
    down[idx, cols] = np.maximum(x[cols] - step[cols], lower[cols])
    values = np.asarray(func(np.vstack([up, down])), dtype=float)
    f_up, f_down = values[:k], values[k:]
    ok_up = np.all(np.isfinite(f_up), axis=1)
    ok_down = np.all(np.isfinite(f_down), axis=1)
    h_up = up[idx, cols] - x[cols]
    h_down = x[cols] - down[idx, cols]
    jac = np.zeros((f0.size, k))
    for i in range(k):
        if ok_up[i] and ok_down[i] and h_up[i] + h_down[i] > 0:
            jac[:, i] = (f_up[i] - f_down[i]) / (h_up[i] + h_down[i])
        elif ok_up[i] and h_up[i] > 0:
            jac[:, i] = (f_up[i] - f0) / h_up[i]
        elif ok_down[i] and h_down[i] > 0:
            jac[:, i] = (f0 - f_down[i]) / h_down[i]
    return jac


def central_differences(
    func: Callable[[NDArray], NDArray],
    x: ArrayLike,
    f0: ArrayLike,
    *,
    step: float | ArrayLike,
    lower: float | ArrayLike = -np.inf,
    upper: float | ArrayLike = np.inf,
    columns: ArrayLike | None = None,
    richardson: bool = False,
) -> NDArray:
    """Jacobian ``d func / dx`` at ``x`` (module docstring).

    Parameters
    ----------
    func : callable
        ``func(X) -> F`` for ``X`` of shape ``(k, m)``, ``F`` of shape ``(k, r)``; rows whose
        value does not exist are NaN.
    x : array_like, shape (m,)
    f0 : array_like, shape (r,)
        ``func`` at ``x`` (finite).
    step : float or array_like of shape (m,)
        Displacement per variable (in the variables' units).
    lower, upper : float or array_like of shape (m,)
        Bounds the displaced points are clipped to.
    columns : array_like of int, optional
        Only these variables; the others get zero columns.
    richardson : bool
        Combine steps ``h`` and ``h/2`` (two evaluations of ``func``).

    Returns
    -------
    ndarray of shape (r, m)
    """
    x = np.asarray(x, dtype=float)
    f0 = np.asarray(f0, dtype=float)
    m = x.size
    cols = np.arange(m) if columns is None else np.asarray(columns, dtype=np.int64)
    step = np.broadcast_to(np.asarray(step, dtype=float), (m,))
    lower = np.broadcast_to(np.asarray(lower, dtype=float), (m,))
    upper = np.broadcast_to(np.asarray(upper, dtype=float), (m,))
    jac = np.zeros((f0.size, m))
    if cols.size == 0:
        return jac
    coarse = _one_step(func, x, f0, cols, step, lower, upper)
    if richardson:
        fine = _one_step(func, x, f0, cols, step / 2.0, lower, upper)
        coarse = (4.0 * fine - coarse) / 3.0
    jac[:, cols] = coarse
    return jac
