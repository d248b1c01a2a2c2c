"""Benchmarks: our kernels and a baseline, side by side in one process.

Each module registers a ``dpfexplore bench NAME`` subcommand. Times are medians over repeats
(these machines are shared and noisy); every speed figure comes with its error against a trusted
reference, and compile time is reported apart from run time. ``--save`` writes the record to
``results/reports/bench-NAME.json``.

Modules
-------
_common
    Machine facts, repeat-and-median timing, fresh-process compile timings, option types, output.
numpy_model
    The lattice energy and gradient in vectorised NumPy: the SciPy baseline, and a test oracle.
statics, sensitivities, snap
    The all-inverted state and tip stiffness against SciPy; design sensitivities against finite
    differences; snap pressures by continuation against the slow-ramp limit.
dynamics, reset_model
    Reset-time evaluation, every method against its error; the fast reset-time model against
    the full model.
sweep, lookup, surrogate
    Sweep jobs end to end, local and Dask; a lookup index on a million rows; surrogates against
    the exact model.
design, design_timing
    The inverse-design optimiser against black-box optimisers (Optuna TPE, GP); the timing
    scenes at equal wall time.
identify, unitcell
    Identification's speed and accuracy; one dome's curve against the mesh error, a grid of
    curves, and the solid cross-check side by side.
grasp
    One grasp, the sorting loop over many objects and the sorting map, and the contact's error
    against the tightest penetration tolerance.
"""
