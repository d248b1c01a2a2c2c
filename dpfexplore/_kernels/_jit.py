"""The project's one JIT policy.

Every Numba function in :mod:`dpfexplore._kernels` is decorated through :func:`kernel` or
:func:`batch_kernel`, so the options live in one place:

* ``cache=True`` everywhere: compiled machine code is written next to the sources and reused by
  later processes (sweep workers load it instead of compiling). Several processes writing the
  cache at once is a known source of crashes, so engines compile in the parent first
  (:func:`dpfexplore.sweep.warmup.compile_kernels`).
* ``nogil=True`` on per-design kernels, so threads (and prange bodies) can call them
  concurrently; they touch only their own arguments.
* ``parallel=True`` only on batch kernels, which ``prange`` over designs.
* No ``fastmath``: it has not been shown to leave results within tolerance (the dome energy near
  the saddle-node bifurcation is a difference of nearly equal terms), so it stays off.
* No object mode: ``njit`` fails loudly instead of falling back.

Importing this module first clears cached kernels compiled from other versions of the sources
(:func:`._cache.invalidate_stale_cache`), so a kernel decorated here never loads stale code.
"""

from __future__ import annotations

import numba

from ._cache import invalidate_stale_cache

invalidate_stale_cache()

_COMMON = {"cache": True, "error_model": "numpy"}


def kernel(func=None, /, **overrides):
    """Compile a per-design kernel (``njit(cache=True, nogil=True)``)."""
    options = {**_COMMON, "nogil": True, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)


def batch_kernel(func=None, /, **overrides):
    """Compile a batch kernel that ``prange``-s over designs (``parallel=True``)."""
    options = {**_COMMON, "nogil": True, "parallel": True, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)
