"""Snap pressures: the states a slow pressure ramp visits (quasi-static continuation).

Modules
-------
continuation
    :func:`~.continuation.snap_pressures`, :func:`~.continuation.inversion_pressure`: folds of
    the loaded equilibrium found by pseudo-arclength continuation, landings by the dynamics.
batch
    :func:`~.batch.snap_pressures_batch`, :func:`~.batch.inversion_pressures_batch`: the
    rising ramp of many designs in parallel.
settings
    The ramp's default end, the landing models and the checks every entry point shares.
results
    :class:`~.results.SnapSequence` and its events and visited states.
"""
