"""Numerical building blocks shared by the stages (NumPy only, no model knowledge).

Modules
-------
differences
    :func:`~.differences.central_differences`: the one finite-difference Jacobian of the
    package (inverse design's fallback, lookup's polish baseline, the sensitivity benchmark).
"""
