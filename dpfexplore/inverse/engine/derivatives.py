"""Derivatives of a scene's outputs with respect to the box variables ``z``.

The optimiser's fallback Jacobian: scenes take their Jacobians from the model's exact
sensitivities (``solve_batch(..., sensitivities=True)`` chained with
:meth:`DesignVariables.jacobian`, :meth:`.scenes.Problem.jacobian`) and use these central
differences of the exact model only where those are undefined (a row whose Hessian is not
positive definite, an output without sensitivities). The ``2m`` displaced designs of a
stencil are solved in one batch, and a displacement that would leave ``[0, 1]`` is clipped to
the box, so every design evaluated for a derivative honours
the scene's bounds and constraints (the box map is exact). A displaced design whose targeted
state does not exist (it collapses) is dropped from its pair and the difference is taken
one-sided from the centre; a variable with both sides collapsed gets a zero derivative, so the
step cannot move along it.

The model's equilibria are converged far below the step's effect (Newton's last step is taken
in the quadratic regime), so a step of ``1e-5`` in ``z`` (``2e-5`` mm on a height range of 2 mm)
gives derivatives to about five digits, well beyond what the trust-region steps need.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["STEP", "central_differences"]

#: Displacement in ``z`` of the central differences.
STEP = 1e-5


def central_differences(
    func: Callable[[NDArray], NDArray],
    z: NDArray,
    f0: NDArray,
    *,
    step: float = STEP,
    columns: NDArray | None = None,
) -> NDArray:
    """Jacobian ``d func / dz`` at ``z`` by central differences clipped to the box.

    Parameters
    ----------
    func : callable
        ``func(Z) -> F`` for ``Z`` of shape ``(k, m)`` in ``[0, 1]``, ``F`` of shape ``(k, r)``;
        rows whose value does not exist are NaN.
    z : ndarray of shape (m,)
    f0 : ndarray of shape (r,)
        ``func`` at ``z`` (finite).
    step : float
    columns : ndarray of int, optional
        Only these variables (the others get zero columns, e.g. variables the caller
        differentiates analytically).

    Returns
    -------
    ndarray of shape (r, m)
    """
    z = np.asarray(z, dtype=float)
    m = z.size
    cols = np.arange(m) if columns is None else np.asarray(columns, dtype=np.int64)
    jac = np.zeros((f0.size, m))
    if cols.size == 0:
        return jac
    up = np.repeat(z[None, :], cols.size, axis=0)
    down = up.copy()
    idx = np.arange(cols.size)
    up[idx, cols] = np.minimum(z[cols] + step, 1.0)
    down[idx, cols] = np.maximum(z[cols] - step, 0.0)
    values = func(np.vstack([up, down]))
    f_up, f_down = values[: cols.size], values[cols.size :]
    ok_up = np.all(np.isfinite(f_up), axis=1)
    ok_down = np.all(np.isfinite(f_down), axis=1)
    h_up = up[idx, cols] - z[cols]
    h_down = z[cols] - down[idx, cols]
    for i, j in enumerate(cols):
        if ok_up[i] and ok_down[i] and h_up[i] + h_down[i] > 0:
            jac[:, j] = (f_up[i] - f_down[i]) / (h_up[i] + h_down[i])
        elif ok_up[i] and h_up[i] > 0:
            jac[:, j] = (f_up[i] - f0) / h_up[i]
        elif ok_down[i] and h_down[i] > 0:
            jac[:, j] = (f0 - f_down[i]) / h_down[i]
    return jac
