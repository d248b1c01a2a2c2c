"""dpfexplore: a Numba-accelerated design-space explorer for multistable Dome Phalanx Fingers.

The model is the spring lattice of Osorio et al., "Embodying Control in Soft Multistable Grippers
from Morphofunctional Co-design", as specified in MODEL.md. The package reads like its pipeline:

design
    :class:`Design`, :class:`DesignBatch`, materials, TOML loading; all input validation.
constants
    Closed-form spring constants and isolated-dome analysis (MODEL.md §3-§4).
lattice
    From designs to kernel arrays; :func:`spring_constants`.
_kernels
    Numba only: energy/gradient/Hessian, Newton, state search, batch entry points, dynamics.
statics
    :func:`find_state`, :func:`enumerate_states`, :func:`solve_batch` (MODEL.md §6-§7).
follower, scenes
    Follower-force stiffness (validation path); gripper apertures.
dynamics
    Pressure pulses, integrators, snap and reset times (MODEL.md §8).
space, sampling, sweep, store, engines
    Job specs, Latin-hypercube plans, chunked evaluation into Parquet, local and Dask engines.
plotting
    ``plot_*(..., ax=None) -> Axes``.
cli, bench
    The ``dpfexplore`` command and its benchmarks.

Units throughout: mm, N, MPa, tonne, s (energy N·mm, stiffness N/mm).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _distribution_version

from .design import MATERIALS, Design, DesignBatch, Material, load_design
from .dynamics import PressureProfile, SimulationResult, reset_times_batch, simulate
from .lattice import spring_constants
from .space import load_job
from .statics import (
    SolverOptions,
    StateResult,
    enumerate_states,
    find_state,
    sequential_states,
    solve_batch,
)
from .status import Status
from .store import read_results
from .sweep import run_sweep

try:
    __version__ = _distribution_version("dpfexplore")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0+unknown"

__all__ = [
    "MATERIALS",
    "Design",
    "DesignBatch",
    "Material",
    "PressureProfile",
    "SimulationResult",
    "SolverOptions",
    "StateResult",
    "Status",
    "enumerate_states",
    "find_state",
    "load_design",
    "load_job",
    "read_results",
    "reset_times_batch",
    "run_sweep",
    "sequential_states",
    "simulate",
    "solve_batch",
    "spring_constants",
]
