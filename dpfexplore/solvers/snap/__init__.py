"""Snap pressures: the states a slow pressure ramp visits (quasi-static continuation).

Modules
-------
continuation
    :func:`~.continuation.snap_pressures`, :func:`~.continuation.inversion_pressure`: folds of
    the loaded equilibrium found by pseudo-arclength continuation, landings by the dynamics.
results
    :class:`~.results.SnapSequence` and its events and visited states.
"""
