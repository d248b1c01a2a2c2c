"""Dynamics of the damped lattice under pressure (MODEL.md §8), and the reset-time models.

Modules
-------
common, methods
    Controls, results, unit classes and the batch runner shared by the dynamics front ends; the
    integration methods by name, their tolerances and step caps (what the CLI offers without
    importing Numba).
scipy_baseline
    The trusted baseline: the same equations through ``scipy.integrate.solve_ivp``.
release
    The release model, a reduced reset-time model with its error measured.
reset_model, fast_reset
    The fast reset-time model (``reset_times_batch(..., method="fast")``): its JSON model file
    (trees, interval); the physical core, fitted correction and fallback. Its training lives with
    the other learned models (:mod:`dpfexplore.surrogates.reset_training`).
simulate
    :func:`~.simulate.simulate` and :func:`~.simulate.reset_times_batch`.
resetmaps
    The paper's metastable-dome maps (reset time against H, t and hold time).
ramp
    Inversion pressures from slow pressure ramps (extrapolated to the quasi-static fold).
"""
