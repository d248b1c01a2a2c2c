"""The on-disk cache of compiled kernels, kept in step with the sources they are compiled from.

Numba invalidates a cached function only when *its own* file changes, not when a function it
calls (and inlines) from another file does: after an edit of ``lattice.py`` the cached batch
kernel of ``statics/batch.py`` would keep the old energy. So the cache carries a digest of every
source the kernels compile, and a mismatch clears it (:func:`invalidate_stale_cache`, run by
:mod:`._jit` before any kernel is compiled or loaded).

Which sources: all of ``_kernels/``, and every ``dpfexplore`` module they import, found by
walking their import statements (:func:`kernel_sources`; their syntax trees, not their
execution), transitively: the closed forms and validation rules of ``model/`` that kernels
compile inline, the status codes, limits and quantity tables they read as compile-time
constants, and whatever those import in turn. A module that a kernel starts to import is covered
without being listed anywhere; a module no kernel reaches (``cli/``, ``sweep/``) leaves the
digest alone. An installed package never changes, so the clean-up only ever acts during
development.

Walking the imports costs about 0.2 s of CPU, paid by every process that loads a kernel (each
command, test worker and sweep worker). So the digest is remembered beside the kernels with the
size and modification time of every source it covers (:func:`current_digest`): while none of
them changes and no module is added to ``_kernels/``, it is read back instead of recomputed.
That is the test Numba itself applies to a cached kernel's own file; a source edited without a
change of size or time would escape both.
"""

from __future__ import annotations

import ast
import hashlib
import json
import logging
import os
from collections.abc import Iterator
from pathlib import Path

import numba

from ..io.files import BoundedReadError, atomic_write, read_bounded

__all__ = [
    "KERNELS_DIR",
    "current_digest",
    "invalidate_stale_cache",
    "is_cached",
    "kernel_sources",
    "sources_digest",
]

logger = logging.getLogger(__name__)

#: The kernels' package folder, ``dpfexplore/_kernels``.
KERNELS_DIR = Path(__file__).parent
_MARKER = "dpfexplore-sources.sha256"
_STAMP = "dpfexplore-sources.stamp.json"


def _module_name(path: Path, top: Path) -> str:
    """Dotted name of the module in ``path`` under the folder ``top`` holding the package."""
    parts = path.relative_to(top).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _module_file(name: str, top: Path) -> Path | None:
    """The source file of module ``name`` under ``top``: ``a/b.py`` or ``a/b/__init__.py``."""
    base = top.joinpath(*name.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _imported_files(path: Path, top: Path, package: str) -> Iterator[Path]:
    """Source files of the modules of ``package`` that ``path`` imports (anywhere in it).

    ``from P import n`` names module ``P.n`` if that is a module, else an attribute of ``P``
    (then ``P`` itself is the import); relative imports resolve against ``path``'s package.
    """
    own = _module_name(path, top)
    here = own if path.name == "__init__.py" else own.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_bytes(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [(alias.name, ()) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = here.split(".")
                base = parts[: len(parts) - (node.level - 1)]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            targets = [(name, tuple(alias.name for alias in node.names))]
        else:
            continue
        for name, members in targets:
            if name.split(".")[0] != package:
                continue
            submodules = [_module_file(f"{name}.{member}", top) for member in members]
            yield from (file for file in submodules if file is not None)
            if not members or None in submodules:
                module = _module_file(name, top)
                if module is not None:
                    yield module


def kernel_sources(kernels_dir: Path = KERNELS_DIR) -> list[Path]:
    """Every source the kernels are compiled from, sorted.

    The ``.py`` files under ``kernels_dir`` and, transitively, every module of its top-level
    package (``kernels_dir``'s parent folder) that one of them imports.
    """
    package_dir = kernels_dir.parent
    top = package_dir.parent
    pending = sorted(kernels_dir.rglob("*.py"))
    found: set[Path] = set()
    while pending:
        path = pending.pop()
        if path in found:
            continue
        found.add(path)
        pending.extend(_imported_files(path, top, package_dir.name))
    return sorted(found)


def sources_digest(kernels_dir: Path = KERNELS_DIR) -> str:
    """SHA-256 over the paths and contents of :func:`kernel_sources`."""
    return _digest(kernel_sources(kernels_dir), kernels_dir.parent.parent)


def _digest(sources: list[Path], top: Path) -> str:
    digest = hashlib.sha256()
    for path in sources:
        digest.update(path.relative_to(top).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _stat(path: Path) -> list[int]:
    info = os.stat(path)
    return [info.st_size, info.st_mtime_ns]


def current_digest(kernels_dir: Path = KERNELS_DIR, stamp: Path | None = None) -> str:
    """:func:`sources_digest`, read back from ``stamp`` while no source has changed.

    Parameters
    ----------
    kernels_dir : Path
        The kernels' package folder.
    stamp : Path, optional
        The remembered digest: JSON with the digest and each source's path, size (bytes) and
        modification time (ns). Default ``kernels_dir/__pycache__/dpfexplore-sources.stamp.json``.

    Returns
    -------
    str
        The digest, recomputed (and the stamp rewritten, where it can be) when a source's size or
        time differs from the stamp's, a source is gone, or ``kernels_dir`` holds a module the
        stamp does not list.
    """
    top = kernels_dir.parent.parent
    stamp = stamp if stamp is not None else kernels_dir / "__pycache__" / _STAMP
    try:
        recorded = json.loads(read_bounded(stamp, "kernel sources stamp"))
        files = {name: size_time for name, *size_time in recorded["files"]}
        own = {path.relative_to(top).as_posix() for path in kernels_dir.rglob("*.py")}
        if own <= files.keys() and all(_stat(top / n) == st for n, st in files.items()):
            return str(recorded["digest"])
    except (OSError, BoundedReadError, ValueError, KeyError, TypeError):
        pass  # no stamp yet, or one from other sources: recompute
    sources = kernel_sources(kernels_dir)
    times = [[path.relative_to(top).as_posix(), *_stat(path)] for path in sources]  # before reading
    digest = _digest(sources, top)
    try:
        stamp.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(stamp, json.dumps({"digest": digest, "files": times}))
    except OSError:
        pass  # a read-only install: recomputed by every process, as Numba caches nothing there
    return digest


def _cache_dirs() -> list[Path]:
    """Where Numba caches the kernels: beside the sources, or under ``NUMBA_CACHE_DIR``.

    One folder per package of kernels (Numba keeps a cache beside each source file).
    """
    packages = sorted({path.parent for path in KERNELS_DIR.rglob("*.py")})
    dirs = [package / "__pycache__" for package in packages]
    if numba.config.CACHE_DIR:
        from numba.core.caching import _CacheLocator

        for package in packages:
            subpath = _CacheLocator.get_suitable_cache_subpath(str(package / "__init__.py"))
            dirs.append(Path(numba.config.CACHE_DIR) / subpath)
    return dirs


def clear_stale(digest: str, dirs: list[Path]) -> int:
    """Delete the cached kernels of every folder in ``dirs`` not marked with ``digest``.

    Marks each folder with ``digest`` afterwards; returns the number of files deleted. Folders
    that cannot be written (a read-only install, where Numba does not cache either) are skipped.
    """
    deleted = 0
    for directory in dirs:
        marker = directory / _MARKER
        try:
            if marker.exists() and marker.read_text() == digest:
                continue
            stale = [*directory.glob("*.nbi"), *directory.glob("*.nbc")]
            for path in stale:
                path.unlink(missing_ok=True)
            directory.mkdir(parents=True, exist_ok=True)
            marker.write_text(digest)
            deleted += len(stale)
            if stale:
                logger.info("cleared %d stale cached kernels in %s", len(stale), directory)
        except OSError:
            continue
    return deleted


def invalidate_stale_cache() -> None:
    """Drop cached kernels compiled from other versions of the kernel sources."""
    clear_stale(current_digest(), _cache_dirs())


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
