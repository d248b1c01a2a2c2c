"""The settings of a scene's fallback Jacobian in the box variables ``z``.

The differences themselves are the package's one routine,
:func:`dpfexplore.numerics.differences.central_differences`, called by
:meth:`dpfexplore.inverse.engine.problem.Problem.jacobian` with these settings. The optimiser's
fallback Jacobian: scenes take their Jacobians from the model's exact
sensitivities (``solve_batch(..., sensitivities=True)`` chained with
:meth:`DesignVariables.jacobian`, :meth:`.problem.Problem.jacobian`) and use these central
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

__all__ = ["BOX_BOUNDS", "STEP"]

#: Displacement in ``z`` of the central differences.
STEP = 1e-5
#: The box every displaced point is clipped to (the variables' unit box).
BOX_BOUNDS = (0.0, 1.0)
