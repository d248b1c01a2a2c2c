"""Result directories that are complete or absent: one way to write every command's results.

``design --out``, ``lookup --write``, ``surrogate fit --out``, ``reset-maps --out`` and
``identify fit --out`` all write a directory of files. :func:`result_directory` gives them the
sweep's guarantees:

* the files are written into a **staging** sibling ``.NAME.staging-<id>`` (same filesystem),
  then a manifest ``.dpfexplore-result.json`` listing every file's size and SHA-256 is written
  **last**, and the staging directory is swapped into place in one step: Linux ``renameat2``
  with ``RENAME_EXCHANGE`` when the target exists (the previous result stays whole until the
  swap), a plain ``rename`` when it does not. Where ``renameat2`` is unavailable the previous
  result is first renamed to ``.NAME.old-<id>``; a crash between the two renames is repaired
  by the next writer (it restores the previous result), and so are the staging directories of
  writers that were killed (removed once their pid is gone);
* a failure or Ctrl-C before the swap removes the staging directory: the previous result is
  untouched, no half result is ever visible under ``NAME``;
* two writers of one ``NAME`` cannot interleave: a lock file ``.NAME.dpfexplore-lock`` beside it
  (:func:`dpfexplore.io.lock.file_lock`) refuses the second;
* a directory that holds anything is replaced only with ``force`` (one line naming what is
  there), and never when it is a sweep dataset, the working directory or one of its parents, the
  home directory or ``/``.

:func:`check_output_dir` does the path checks alone, so commands can refuse a bad ``--out``
before minutes of work. :func:`verify_result_dir` checks a result against its manifest before
it is used (``surrogate report`` / ``predict``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import os
import shutil
import time
import uuid
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

from .commits import MANIFEST as _SWEEP_MANIFEST
from .files import atomic_write, file_sha256, fsync_dir, read_bounded
from .lock import LockHeld, file_lock

__all__ = [
    "RESULT_MARKER",
    "ResultError",
    "ResultExists",
    "check_output_dir",
    "read_result_marker",
    "result_directory",
    "verify_result_dir",
]

#: The manifest of a result directory, written last.
RESULT_MARKER = ".dpfexplore-result.json"
#: Identifies the manifest's layout.
RESULT_FORMAT = "dpfexplore-result/1"
#: Name patterns of a previous result set aside by the two-rename fallback (``previous`` is the
#: name used by earlier versions; both are recovered).
_ASIDE_PATTERNS = (".{name}.old-*", ".{name}.previous-*")


class ResultError(ValueError):
    """A result directory that cannot be written here, or does not match its manifest."""


class ResultExists(ResultError):
    """The target directory holds something and ``force`` was not given."""


def read_result_marker(path: str | Path) -> dict[str, Any] | None:
    """The manifest of result directory ``path``, None if it has none or it is unreadable."""
    try:
        data = json.loads(read_bounded(Path(path) / RESULT_MARKER, "record"))
    except (OSError, ValueError, RecursionError):
        return None
    return data if isinstance(data, dict) else None


def _describe(path: Path) -> str:
    marker = read_result_marker(path)
    if marker is not None:
        return f"a {marker.get('kind', 'dpfexplore')} result of {marker.get('created', '?')}"
    names = sorted(p.name for p in path.iterdir())[:3]
    return "files that are not a dpfexplore result (" + ", ".join(names) + ", ...)"


def check_output_dir(path: str | Path, *, option: str = "--out", force: bool = False) -> Path:
    """``path`` checked as the target of a result directory, before any work.

    Parameters
    ----------
    path : str or Path
        The result directory to be written.
    option : str
        The command-line option that named it, for messages (``--out``, ``--write``).
    force : bool
        Accept a directory that already holds something (it will be replaced).

    Returns
    -------
    Path
        ``path``, its parent folder created.

    Raises
    ------
    ResultError
        For an empty path, ``.``/``..``/``/``/home/working directory or a parent of it, a file,
        a sweep dataset, or a folder that cannot be created.
    ResultExists
        For a non-empty directory without ``force``.
    """
    text = str(path)
    if not text.strip():
        raise ResultError(f"{option}: empty directory name")
    path = Path(path)
    if path.name in ("", ".", "..") or text.rstrip("/").endswith(("/.", "/..")):
        raise ResultError(f"{option} {text}: name a directory of its own, not '.' or '..'")
    resolved = path.resolve()
    cwd = Path.cwd().resolve()
    if resolved in (Path(resolved.anchor), Path.home().resolve()) or resolved in (
        cwd,
        *cwd.parents,
    ):
        raise ResultError(f"{option} {text}: refusing to replace {resolved}")
    if path.exists() and not path.is_dir():
        raise ResultError(f"{option} {text}: is a file, not a directory")
    if (path / _SWEEP_MANIFEST).exists():
        raise ResultError(f"{option} {text}: is a sweep dataset; give a directory of its own")
    if path.is_dir() and any(path.iterdir()) and not force:
        raise ResultExists(f"{option} {text}: holds {_describe(path)}; use --force to replace it")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ResultError(
            f"{option} {text}: cannot create {path.parent} ({exc.strerror or exc})"
        ) from None
    return path


def _files(root: Path) -> list[Path]:
    return sorted(
        p
        for p in root.rglob("*")
        if p.is_file() and p.relative_to(root).as_posix() != RESULT_MARKER
    )


def _write_marker(root: Path, kind: str, description: dict[str, Any] | None) -> None:
    files = {}
    for path in _files(root):
        with open(path, "rb+") as fh:  # flush every file before the marker says it is there
            os.fsync(fh.fileno())
        files[path.relative_to(root).as_posix()] = {
            "bytes": path.stat().st_size,
            "sha256": file_sha256(path),
        }
    for directory in {p.parent for p in _files(root)} | {root}:
        fsync_dir(directory)
    marker = {
        "format": RESULT_FORMAT,
        "kind": kind,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "files": files,
        "description": description or {},
    }
    atomic_write(root / RESULT_MARKER, json.dumps(marker, indent=1, sort_keys=True) + "\n")


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); False where that is unavailable."""
    if os.environ.get("DPFEXPLORE_NO_RENAMEAT2"):  # the fallback, exercised by the tests
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_uint,
    ]
    result = renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if result == 0:
        return True
    errno = ctypes.get_errno()
    if errno in (38, 22, 95):  # ENOSYS, EINVAL, EOPNOTSUPP: not on this kernel/filesystem
        return False
    raise OSError(errno, os.strerror(errno), str(b))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def _recover(path: Path) -> None:
    """Repair what killed writers left beside ``path`` (called with the lock held).

    A previous result set aside by a writer killed between its two renames goes back in place
    when ``path`` is missing (it is the last complete result), and is deleted otherwise (the
    swap completed). Staging directories whose writer (the pid in their name) is no longer
    alive are deleted: nothing will ever complete them, and they hold a whole result's worth of
    disk. The pid check is belt and braces: the lock already excludes a live local writer.
    """
    asides = sorted(
        (
            a
            for pattern in _ASIDE_PATTERNS
            for a in path.parent.glob(pattern.format(name=path.name))
        ),
        key=lambda p: p.stat().st_mtime,
    )
    if asides and not path.exists():
        os.rename(asides.pop(), path)
        fsync_dir(path.parent)
    for aside in asides:
        shutil.rmtree(aside, ignore_errors=True)
    for staging in path.parent.glob(f".{path.name}.staging-*"):
        pid = staging.name.rsplit(".staging-", 1)[1].split("-", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            shutil.rmtree(staging, ignore_errors=True)


def _swap_into_place(staging: Path, path: Path) -> None:
    if not path.exists():
        os.rename(staging, path)
    elif _exchange(staging, path):
        shutil.rmtree(staging)  # now holds the previous result
    else:
        aside = path.with_name(f".{path.name}.old-{uuid.uuid4().hex[:8]}")
        os.rename(path, aside)
        os.rename(staging, path)
        shutil.rmtree(aside)
    fsync_dir(path.parent)


@contextmanager
def result_directory(
    path: str | Path,
    *,
    kind: str,
    force: bool = False,
    description: dict[str, Any] | None = None,
    option: str = "--out",
) -> Iterator[Path]:
    """Write a result directory completely or not at all (module docstring).

    Yields the staging directory to write into; on a normal exit it becomes ``path``.

    Parameters
    ----------
    path : str or Path
        The result directory.
    kind : str
        What it holds (``"design"``, ``"surrogate"``, ...), recorded in its manifest.
    force : bool
        Replace a directory that holds something (never a sweep dataset).
    description : dict, optional
        JSON-ready facts recorded in the manifest.
    option : str
        The command-line option that named ``path``, for messages.

    Yields
    ------
    Path
        The staging directory ``PARENT/.NAME.staging-<pid>-<id>``: write every file there.

    Raises
    ------
    ResultExists
        ``path`` holds something and ``force`` is False (checked before the block runs).
    ResultError
        ``path`` is not a directory of its own (see :func:`check_output_dir`), or another
        command is writing it (its lock is held).
    """
    path = check_output_dir(path, option=option, force=force)
    lock = path.with_name(f".{path.name}.dpfexplore-lock")
    with ExitStack() as stack:
        try:
            stack.enter_context(file_lock(lock, f"{option} {path}: another command is writing it"))
        except LockHeld as exc:
            raise ResultError(str(exc)) from None
        except OSError as exc:  # the lock file cannot be written (a full disk): name the result
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        _recover(path)
        check_output_dir(path, option=option, force=force)  # again, now that we hold the lock
        staging = path.with_name(f".{path.name}.staging-{os.getpid()}-{uuid.uuid4().hex[:8]}")
        staging.mkdir()
        try:
            yield staging
            _write_marker(staging, kind, description)
            _swap_into_place(staging, path)
        except OSError as exc:
            if exc.filename is None:  # a write or fsync names no file: name the result
                raise OSError(exc.errno, exc.strerror, str(path)) from exc
            raise
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)


def verify_result_dir(path: str | Path) -> dict[str, Any]:
    """The manifest of ``path`` after checking every file it lists (size and SHA-256).

    Raises
    ------
    ResultError
        Naming the first problem: no manifest, a missing, changed or unlisted file.
    """
    path = Path(path)
    marker = read_result_marker(path)
    if marker is None or not isinstance(marker.get("files"), dict):
        raise ResultError(f"{path}: not a complete dpfexplore result (no readable {RESULT_MARKER})")
    for name, record in marker["files"].items():
        file = path / name
        if not file.is_file():
            raise ResultError(f"{path}: {name} is missing")
        if file.stat().st_size != record.get("bytes") or file_sha256(file) != record.get("sha256"):
            raise ResultError(f"{path}: {name} changed after it was written")
    unlisted = [p.relative_to(path).as_posix() for p in _files(path)]
    extra = sorted(set(unlisted) - set(marker["files"]))
    if extra:
        raise ResultError(f"{path}: {extra[0]} is not part of the result")
    return marker
