"""The project's one JIT policy.

Every Numba function in :mod:`dpfexplore._kernels` is decorated through :func:`kernel`,
:func:`batch_kernel` or :func:`jitable`, so the options live in one place:

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
* :func:`jitable` (Numba's ``register_jitable``) for plain-arithmetic functions that NumPy code
  runs as Python too: the closed forms and validation rules of :mod:`dpfexplore.model`, which
  imports no Numba (:mod:`.tables.model_forms` compiles them), and the constants set's
  evaluation (:mod:`.tables.set_forms`). Each is compiled inline into every kernel that calls
  it, with Numba's default options, and has no cache of its own.

Importing this module first clears cached kernels compiled from other versions of the sources
(:func:`._cache.invalidate_stale_cache`), so a kernel decorated here never loads stale code.
"""

from __future__ import annotations

import numba
from numba.extending import register_jitable

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


def jitable(func):
    """Let kernels compile ``func`` inline; called from Python it stays the plain function.

    Returns ``func`` itself (Numba's ``register_jitable``): it must be plain arithmetic and
    calls to other functions the kernels can compile.
    """
    return register_jitable(func)
