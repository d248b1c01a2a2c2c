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
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path

import numba

logger = logging.getLogger(__name__)

_KERNELS_DIR = Path(__file__).parent
_MARKER = "dpfexplore-sources.sha256"


def _kernel_sources_digest() -> str:
    digest = hashlib.sha256()
    # The kernels also read the status codes, the domain limits and the indices of the
    # quantities tables as compile-time constants, and compile inline the closed forms of
    # constants.py, a constants set's evaluation (closed_form.py) and the status rules of
    # validation.py.
    model = _KERNELS_DIR.parent / "model"
    names = (
        "status.py",
        "limits.py",
        "domain.py",
        "quantities.py",
        "constants.py",
        "closed_form.py",
        "validation.py",
    )
    extra = [model / name for name in names]
    for path in [*sorted(_KERNELS_DIR.rglob("*.py")), *extra]:
        digest.update(path.relative_to(_KERNELS_DIR.parent).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _cache_dirs() -> list[Path]:
    """Where Numba caches the kernels: beside the sources, or under ``NUMBA_CACHE_DIR``.

    One folder per package of kernels (Numba keeps a cache beside each source file).
    """
    packages = sorted({path.parent for path in _KERNELS_DIR.rglob("*.py")})
    dirs = [package / "__pycache__" for package in packages]
    if numba.config.CACHE_DIR:
        from numba.core.caching import _CacheLocator

        for package in packages:
            subpath = _CacheLocator.get_suitable_cache_subpath(str(package / "__init__.py"))
            dirs.append(Path(numba.config.CACHE_DIR) / subpath)
    return dirs


def invalidate_stale_cache() -> None:
    """Drop cached kernels compiled from other versions of the kernel sources.

    Numba invalidates a cached function only when *its own* file changes, not when a function
    it calls (and inlines) from another file does: after an edit of ``lattice.py`` the cached
    batch kernel in ``batch.py`` would keep the old energy. So the cache carries a digest of all
    kernel sources, and a mismatch clears it. Runs at import, before anything is compiled or
    loaded; an installed package never changes, so this only ever acts during development.
    """
    digest = _kernel_sources_digest()
    for directory in _cache_dirs():
        marker = directory / _MARKER
        try:
            if marker.exists() and marker.read_text() == digest:
                continue
            stale = [*directory.glob("*.nbi"), *directory.glob("*.nbc")]
            for path in stale:
                path.unlink(missing_ok=True)
            directory.mkdir(parents=True, exist_ok=True)
            marker.write_text(digest)
            if stale:
                logger.info("cleared %d stale cached kernels in %s", len(stale), directory)
        except OSError:  # read-only install: Numba falls back to not caching there anyway
            continue


invalidate_stale_cache()


def is_cached(dispatcher) -> bool | None:
    """Whether Numba's cache holds machine code of ``dispatcher`` for this CPU.

    True when its cache index (valid for the current source) has an entry for this machine's
    target, so the first call loads instead of compiling; None when Numba's cache internals
    cannot be read (a Numba version that moved them): the caller then cannot tell.
    """
    try:
        index = dispatcher._cache._cache_file._load_index()
        target = dispatcher.targetctx.codegen().magic_tuple()
    except Exception:  # private Numba API: any failure means "cannot tell"
        return None
    return any(isinstance(key, tuple) and len(key) > 1 and key[1] == target for key in index)


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
