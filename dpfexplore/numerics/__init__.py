"""Numerical building blocks shared by the stages (NumPy only, no model knowledge).

Modules
-------
differences
    :func:`~.differences.central_differences`: the one finite-difference Jacobian of the
    package (inverse design's fallback, lookup's polish baseline, the sensitivity benchmark).
local
    :func:`~.local.least_squares_in_box`: the one local refiner of the package, bounded least
    squares in the unit box that stops at a goal and keeps the best point (inverse design's
    refinement, lookup's polish).
"""
