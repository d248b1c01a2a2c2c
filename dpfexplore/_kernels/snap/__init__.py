"""Snap pressures: equilibrium branches under a slow pressure ramp, folds, landings (Numba).

Modules
-------
continuation
    Pseudo-arclength continuation of the equilibrium under a quasi-static pressure.
landing
    Where a finger comes to rest after a snap, decided by the equations of motion.
walk
    The walk along a finger's branches (one design or many in ``prange``): snap at each fold.
steps
    The stages of one continuation step (trial, stop, crossings, landing).
records
    The walk's output layout and the named records its stages pass.
"""
