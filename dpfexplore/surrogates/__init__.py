"""Surrogates: learned models of the exact model, each with its measured error.

Modules
-------
flat
    Per-output regressors on the flat design vector (knn, gbt, mlp, gp) and the status classifier.
chain_physics, chain
    The chain surrogate: a rigid unit-cell model composed by exact kinematics, with a learned
    per-unit residual and a margin-based status classifier.
data
    Training tables from sweep datasets.
fit
    Fitting every kind on one dataset, with held-out errors.
speed, goals, progress
    The fit's timing on one core, its goals and verdict, and how it shows its progress.
store
    Surrogate sets saved with skops (trusted types only), refused on fingerprint mismatch.
report
    What ``dpfexplore surrogate report`` prints.
reset_training
    Training of the fast reset-time model (:mod:`dpfexplore.solvers.dynamics.reset_model`).
"""
