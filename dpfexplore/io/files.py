"""Writing files so that a reader sees the old contents or the new, never a mixture.

Every stage (constants sets, models, reports, sweeps) writes the same way: to a unique temporary
file in the target's folder, flushed and fsynced, renamed over the target (atomic on POSIX), and
the folder fsynced so that the rename survives a crash.
"""

from __future__ import annotations

import hashlib
import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

__all__ = ["TEMP_SUFFIX", "atomic_write", "atomic_writer", "file_sha256", "fsync_dir"]

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
