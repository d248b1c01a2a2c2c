"""Compile the batch kernels before any worker starts.

Numba compiles on first call and writes machine code to its cache (``cache=True``, see
:mod:`dpfexplore._kernels._jit`). Several processes compiling the same kernel at once write the
same cache files concurrently, a known source of crashes and corrupt caches; so the sweep engines
call :func:`compile_kernels` in the parent process first, and worker processes then only *load* the
cached code. The seconds it takes are reported apart from run time (a cold cache costs tens of
seconds, a warm one well under one).
"""

from __future__ import annotations

import logging
import time

import numpy as np

from ..model.design import Design, DesignBatch
from .space import ComputeSpec

__all__ = ["compile_kernels", "tiny_batch"]

logger = logging.getLogger(__name__)


def tiny_batch() -> DesignBatch:
    """Two small valid designs: one all-bistable, one with a metastable tip unit (MODEL.md §4)."""
    return DesignBatch.from_designs(
        [
            Design(H=[4.0, 4.5], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0),
            Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0),
        ]
    )


def compile_kernels(compute: ComputeSpec | None = None) -> float:
    """Compile (or load from Numba's cache) the batch kernels a sweep calls.

    Parameters
    ----------
    compute : ComputeSpec, optional
        Compile only what this job computes (the static solver always; the dynamics when it asks
        for reset times). None compiles everything.

    Returns
    -------
    float
        Wall time in seconds (compilation or cache loading).
    """
    from ..solvers.statics import warm_up

    start = time.perf_counter()
    batch = tiny_batch()
    # Every state selection and flag is a runtime argument of the same kernels (serial and
    # parallel, which warm_up both runs).
    warm_up(batch)
    if compute is None or compute.reset_times is not None:
        from ..solvers.dynamics.simulate import PressureProfile, reset_times_batch

        profile = PressureProfile(P0=0.7, tau=(0.0, 0.01, 0.02, 0.03))
        reset_times_batch(batch.take(np.array([1])), profile, t_end=0.04)
    if compute is None or (
        compute.reset_times is not None and compute.reset_times.method == "fast"
    ):
        from ..solvers.dynamics.fast_reset import compile_fast_reset

        compile_fast_reset()
    elapsed = time.perf_counter() - start
    logger.info("kernels compiled or loaded from the Numba cache in %.2f s", elapsed)
    return elapsed
