"""Writing files so that a reader sees the old contents or the new, never a mixture; bounded reads.

Every stage (constants sets, models, reports, sweeps) writes the same way: to a unique temporary
file in the target's folder, flushed and fsynced, renamed over the target (atomic on POSIX), and
the folder fsynced so that the rename survives a crash.

A file a user names is read through :func:`read_bounded`: only a regular file (a FIFO, a device
or a directory is refused before anything is read, so ``/dev/zero`` or a named pipe never blocks
or fills memory), and only up to a size the format states.
"""

from __future__ import annotations

import hashlib
import os
import stat
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

__all__ = [
    "TEMP_SUFFIX",
    "BoundedReadError",
    "atomic_write",
    "atomic_writer",
    "file_sha256",
    "fsync_dir",
    "read_bounded",
    "read_json_bounded",
]

#: Suffix of the temporary files (their names also start with a dot: readers skip them).
TEMP_SUFFIX = ".tmp"


def fsync_dir(path: str | Path) -> None:
    """Flush a directory's entries to disk (where the platform allows it)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some filesystems refuse fsync on directories: nothing more to do
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_writer(path: str | Path) -> Iterator[BinaryIO]:
    """A binary file that replaces ``path`` atomically when the block ends without error.

    For writers that stream (``np.savez(fh, ...)``). On any failure (a full disk, Ctrl-C) the
    temporary file is removed and the previous contents of ``path``, if any, are untouched.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:12]}{TEMP_SUFFIX}")
    try:
        with open(tmp, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_dir(path.parent)


def atomic_write(path: str | Path, data: bytes | bytearray | memoryview | str) -> Path:
    """Replace ``path`` with ``data`` atomically (see :func:`atomic_writer`); returns the path."""
    path = Path(path)
    with atomic_writer(path) as fh:
        fh.write(data.encode() if isinstance(data, str) else data)
    return path


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class BoundedReadError(ValueError):
    """A file :func:`read_bounded` refuses: not a regular file, or larger than its limit."""


def read_bounded(path: str | Path, max_bytes: int) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    The file's kind and size are checked before it is read (by ``stat``) and again on the open
    file (it may have been replaced meanwhile); it is opened non-blocking, so a FIFO put in its
    place never blocks, and read no further than ``max_bytes + 1`` bytes.

    Raises
    ------
    BoundedReadError
        ``PATH: is a directory``, ``PATH: not a regular file (...)``, ``PATH: N bytes, more than
        the limit of M``.
    OSError
        As :func:`os.stat` and :func:`os.open` raise it (missing file, no permission).
    """
    path = Path(path)
    info = os.stat(path)
    _check_kind(path, info.st_mode, max_bytes, info.st_size)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        info = os.fstat(fd)
        _check_kind(path, info.st_mode, max_bytes, info.st_size)
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(fd, max_bytes + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    finally:
        os.close(fd)
    if size > max_bytes:  # it grew while read
        raise BoundedReadError(f"{path}: more than the limit of {max_bytes} bytes")
    return b"".join(chunks)


def _check_kind(path: Path, mode: int, max_bytes: int, size: int) -> None:
    if stat.S_ISDIR(mode):
        raise BoundedReadError(f"{path}: is a directory, not a file")
    if not stat.S_ISREG(mode):
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a device or socket"
        raise BoundedReadError(f"{path}: not a regular file ({kind})")
    if size > max_bytes:
        raise BoundedReadError(f"{path}: {size} bytes, more than the limit of {max_bytes}")


def read_json_bounded(path: str | Path, max_bytes: int, *, strict: bool = True) -> object:
    """The JSON document of the regular file ``path`` (at most ``max_bytes``).

    With ``strict`` (the default), ``NaN``, ``Infinity`` and ``-Infinity`` (which Python's
    parser accepts, and JSON does not) are refused; nesting deep enough to exhaust the parser's
    recursion is refused always.

    Raises
    ------
    BoundedReadError
        As :func:`read_bounded` raises it.
    ValueError
        ``not JSON (...)`` with the parser's message and line, or ``nested too deeply``; the
        message does not name the file (callers do).
    OSError
        As :func:`read_bounded` raises it.
    """
    import json

    def refuse(name: str) -> None:
        raise ValueError(f"{name} is not a JSON number")

    data = read_bounded(path, max_bytes)
    try:
        return json.loads(data, parse_constant=refuse if strict else None)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not JSON ({exc.msg}, line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise ValueError("not JSON (not UTF-8 text)") from None
    except RecursionError:
        raise ValueError("not JSON this reader accepts (nested too deeply)") from None
    except ValueError as exc:
        raise ValueError(f"not JSON ({exc})") from None
