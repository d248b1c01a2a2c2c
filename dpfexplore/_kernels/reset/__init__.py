"""Reset times without integrating the whole pulse: the release and fast reset models (Numba).

Modules
-------
reduced
    The release model: a loose loading, a Newton jump to the end of the hold, the release.
loaded_state
    The loaded equilibrium after a long hold, found statically.
release
    Overdamped Rodas3 from the loaded equilibrium to the last reset.
fast_reset
    The fast reset model's physical core.
trees
    Regression-tree ensembles stored as flat arrays (the fast reset model's fitted part).
"""
