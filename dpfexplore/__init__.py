"""dpfexplore: a Numba-accelerated design-space explorer for multistable Dome Phalanx Fingers.

The model is the spring lattice of Osorio et al., "Embodying Control in Soft Multistable Grippers
from Morphofunctional Co-design", as specified in MODEL.md. The packages form a pipeline, listed
here in its order; each imports only the ones before it (``numerics``, ``io`` and ``examples``,
the bottom, import nothing else of the package; ``tests/test_layout.py`` holds the order and
checks it):

numerics
    NumPy building blocks with no model knowledge (the one central-difference routine, the one
    local refiner).
io, examples
    Shared I/O of every stage that writes: atomic files, one writer per directory, chunk files
    committed through a manifest with checksums, result directories complete or absent, the one
    TOML field reader of every input file; the shipped example files (designs and legs, TOML),
    found by name.
model
    Designs and their validation, closed-form spring constants and constants sets, pressure
    profiles, status codes, design variables as a map of the unit box.
_kernels
    Numba only: energy/gradient/Hessian, Newton, state search, batch entry points, dynamics,
    snap continuation, the unit-cell shell.
solvers
    :func:`find_state`, :func:`solve_batch`, :func:`simulate`, :func:`reset_times_batch`,
    :func:`snap_pressures`, legs: the Python API over the kernels (MODEL.md §6-§10).
plotting
    ``plot_*(..., ax=None) -> Axes``; imports only model and solvers.
grasping
    :func:`dpfexplore.grasping.grasp`: the gripper closing on a disk, contact forces, the
    contact sensor, payload per state (MODEL.md §12).
measurements
    Printed fingers as data (the paper's ship with the package) and :func:`validate`: how well
    each constants set predicts them.
sweep
    Job specs, Latin-hypercube plans, chunked evaluation into Parquet, local and Dask engines;
    ``sweep.storage``, the on-disk side (schema, commits, verified reads).
lookup
    Nearest designs of a dataset for target outputs, polished and verified by the exact model.
surrogates
    Learned models of the exact model with their measured errors; the fast reset model's training.
unitcell
    One dome unit's curve from its geometry and material (the shell model), the data source of
    identification.
identification
    From unit-cell curves to spring constants: per-curve fits, closed forms selected by grouped
    RFECV, saved as constants sets.
inverse
    Scenes and the optimiser (inverse design): an engine that imports no scene, one package per
    scene kind.
explore
    The design-space explorer in the browser (``dpfexplore explore``): a dataset's tips on a
    map rasterized on the server, filters, clicks answered by verified designs (Bokeh, an extra).
bench, cli
    The benchmarks and the ``dpfexplore`` command (``__main__``: ``python -m dpfexplore``), on
    top of everything.

Where the three everyday changes go (``docs/layout.md`` lists the files): a new scene kind is one
package under ``inverse/scenes/`` and one entry of ``SCENE_KINDS`` (:mod:`.inverse.kinds`); a
new per-state output column and a new closed form of a constants set are each one row of a table
in :mod:`.model.quantities` plus its computation (the module's docstring has both recipes).

Units throughout: mm, N, MPa, tonne, s (energy N·mm, stiffness N/mm).
"""

from __future__ import annotations

import importlib

#: Public name -> the module that defines it. Imported on first use (PEP 562), so that
#: ``import dpfexplore`` (and every ``dpfexplore`` command's start-up) does not load Numba,
#: SciPy and pandas before they are needed. The package body itself imports nothing but
#: ``importlib``, already loaded by Python and without a from-list (which would run importlib's
#: Python code): it runs before ``__main__`` can catch a Ctrl-C, so it must stay this short.
_EXPORTS = {
    "Design": ".model.design",
    "DesignBatch": ".model.design",
    "MATERIALS": ".model.design",
    "Material": ".model.design",
    "PressureProfile": ".solvers.dynamics.simulate",
    "Sensitivities": ".solvers.sensitivities",
    "SimulationResult": ".solvers.dynamics.simulate",
    "SnapSequence": ".solvers.snap.continuation",
    "SolverOptions": ".solvers.statics",
    "StateResult": ".solvers.statics",
    "Status": ".model.status",
    "enumerate_states": ".solvers.statics",
    "find_state": ".solvers.statics",
    "inversion_pressure": ".solvers.snap.continuation",
    "load_design": ".model.design",
    "load_job": ".sweep.job_file",
    "load_leg": ".solvers.legs.leg",
    "read_results": ".sweep.storage.store",
    "reset_times_batch": ".solvers.dynamics.simulate",
    "run_sweep": ".sweep.driver",
    "sequential_states": ".solvers.statics",
    "simulate": ".solvers.dynamics.simulate",
    "simulate_leg": ".solvers.legs.leg",
    "snap_pressures": ".solvers.snap.continuation",
    "snap_pressures_batch": ".solvers.snap.batch",
    "solve_batch": ".solvers.statics",
    "spring_constants": ".solvers.lattice",
    "validate": ".measurements.validate",
}

__all__ = [
    "MATERIALS",
    "Design",
    "DesignBatch",
    "Material",
    "PressureProfile",
    "Sensitivities",
    "SimulationResult",
    "SnapSequence",
    "SolverOptions",
    "StateResult",
    "Status",
    "enumerate_states",
    "find_state",
    "inversion_pressure",
    "load_design",
    "load_job",
    "load_leg",
    "read_results",
    "reset_times_batch",
    "run_sweep",
    "sequential_states",
    "simulate",
    "simulate_leg",
    "snap_pressures",
    "snap_pressures_batch",
    "solve_batch",
    "spring_constants",
    "validate",
]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("dpfexplore")
    except PackageNotFoundError:  # running from a source tree without installing
        return "0+unknown"


def __getattr__(name: str) -> object:
    if name == "__version__":  # reading the installed metadata costs ~20 ms: on demand
        globals()[name] = value = _version()
        return value
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'dpfexplore' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
