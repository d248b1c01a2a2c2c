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

from numpy.typing import NDArray

from ...numerics.differences import central_differences as shared_central_differences

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
    """Jacobian ``d func / dz`` at ``z`` by central differences clipped to the box ``[0, 1]``.

    The package's one finite-difference routine
    (:func:`dpfexplore.numerics.differences.central_differences`) with the box as bounds.

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
    return shared_central_differences(func, z, f0, step=step, lower=0.0, upper=1.0, columns=columns)
