"""Inverse design: from what a finger must do to verified designs.

Lookup over sweep datasets, surrogates, scenes and the optimiser that solves them build on the
solvers and sweeps below this package.
"""
