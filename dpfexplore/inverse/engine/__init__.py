"""Scene-agnostic numerics of inverse design; imports no scene.

Modules
-------
derivatives
    Central differences in the unit box: the fallback where exact sensitivities are undefined.
optimiser
    Latin-hypercube candidates, trust-region refinement on exact sensitivities, SLSQP fronts.
roots
    Roots along one box variable: grown brackets and Brent's method on clipped log ratios.
seeds
    Candidates from a sweep dataset's lookup index instead of a Latin hypercube.
"""
