"""Scene-agnostic numerics of inverse design; imports no scene and reads no kind.

Whatever a scene kind needs solved is handed in: its problems (subclasses of
:class:`~.problem.Problem`), tolerances, budget (:class:`~.settings.OptimiserSettings`) and, for
roots, the function to root.

Modules
-------
problem
    :class:`~.problem.Problem`: box points to exact model outputs, residuals, Jacobians.
settings
    The optimiser's budget (a scene's ``[optimiser]`` table).
derivatives
    Central differences in the unit box: the fallback where exact sensitivities are undefined.
optimiser
    Latin-hypercube candidates, trust-region refinement on exact sensitivities, SLSQP fronts.
roots
    Roots along one box variable: grown brackets and Brent's method on clipped log ratios.
seeds
    Candidates from a sweep dataset's lookup index instead of a Latin hypercube.
"""
