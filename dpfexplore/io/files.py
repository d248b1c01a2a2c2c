"""Writing files so that a reader sees the old contents or the new, never a mixture; bounded reads.

Every stage (constants sets, models, reports, sweeps) writes the same way: to a unique temporary
file in the target's folder, flushed and fsynced, renamed over the target (atomic on POSIX), and
the folder fsynced so that the rename survives a crash.

A file a user names is read through :func:`read_bounded`: only a regular file (a FIFO, a device
or a directory is refused before anything is read, so ``/dev/zero`` or a named pipe never blocks
or fills memory), and only up to a size its kind allows. :data:`SIZE_LIMITS` is the one table of
those sizes, each with its reason; a file a library opens itself (Parquet, ``.npz``) is checked
the same way first by :func:`check_file`.
"""

from __future__ import annotations

import hashlib
import os
import stat
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

__all__ = [
    "SIZE_LIMITS",
    "TEMP_SUFFIX",
    "BoundedReadError",
    "SizeLimit",
    "atomic_write",
    "atomic_writer",
    "check_file",
    "file_sha256",
    "fsync_dir",
    "read_bounded",
    "read_json_bounded",
    "size_limit",
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
    temporary file is removed and the previous contents of ``path``, if any, are untouched; an
    ``OSError`` that names no file is raised again naming ``path``.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:12]}{TEMP_SUFFIX}")
    try:
        with open(tmp, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if exc.filename is None:  # a write or fsync names no file: name the target
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
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


@dataclass(frozen=True)
class SizeLimit:
    """The largest file of one kind the tool reads.

    Attributes
    ----------
    bytes : int
        The limit, bytes.
    what : str
        The kind of file, as messages name it (``"design file"``).
    reason : str
        Why the limit is where it is: what the largest real file of the kind holds.
    """

    bytes: int
    what: str
    reason: str


_KiB, _MiB, _GiB = 1 << 10, 1 << 20, 1 << 30

#: Every kind of file the tool reads, with its size limit and the reason. A file larger than its
#: limit is refused before it is read; so is anything but a regular file.
SIZE_LIMITS: dict[str, SizeLimit] = {
    "design": SizeLimit(
        64 * _KiB,
        "design file (TOML)",
        "a [design] table of MAX_UNITS units with a [result] table is under 4 KiB",
    ),
    "toml": SizeLimit(1 * _MiB, "TOML file", "a file written by hand: a few tables"),
    "job": SizeLimit(
        1 * _MiB, "job file", "the shipped jobs are under 2 KiB; a job is a few tables"
    ),
    "scene": SizeLimit(
        1 * _MiB,
        "scene file",
        "the shipped scenes are under 4 KiB; 1 MiB holds some ten thousand targets",
    ),
    "leg": SizeLimit(1 * _MiB, "leg file", "a leg is a few sections and phases: a few KiB"),
    "unit-cell job": SizeLimit(
        1 * _MiB, "unit-cell job file", "a unit-cell job is a few tables: a few KiB"
    ),
    "measurements": SizeLimit(
        1 * _MiB,
        "measurement file",
        "the paper's printed fingers are 9 KiB; 1 MiB holds a few thousand fingers",
    ),
    "constants set": SizeLimit(
        1 * _MiB,
        "constants set file",
        "a set is a few closed forms with their hull (the packaged one 7 KiB); 1 MiB leaves room "
        "for long provenance notes and parses in milliseconds",
    ),
    "reset model": SizeLimit(
        16 * _MiB,
        "reset-model file",
        "the packaged model is 80 KiB; 400 trees of depth 5 in both ensembles take about 5 MB",
    ),
    "curve table": SizeLimit(
        512 * _MiB,
        "curve table",
        "a unit-cell sweep of 10,000 geometries of 500 points each is about 300 MB as CSV, a "
        "sixth of that as Parquet",
    ),
    "identification report": SizeLimit(
        64 * _MiB,
        "identification report",
        "one entry per curve fit, a few hundred bytes each",
    ),
    "surrogate metadata": SizeLimit(
        16 * _MiB,
        "surrogate metadata (surrogate.json, report.json)",
        "a surrogate's identity, fingerprints and error tables: tens of KiB",
    ),
    "surrogate models": SizeLimit(
        2 * _GiB,
        "surrogate models (models.skops)",
        "a Gaussian process keeps its training rows: 500 rows per N for every output, a few MB",
    ),
    "designs table": SizeLimit(
        512 * _MiB,
        "designs table (Parquet)",
        "the designs surrogate predict reads: 10^6 designs of a few dozen columns, about 200 MB",
    ),
    "manifest": SizeLimit(
        256 * _MiB,
        "sweep manifest",
        "one record of about 250 bytes per chunk, at most 2^18 chunks (sweep.chunks.MAX_CHUNKS)"
        ", with the job: under 70 MiB",
    ),
    "dataset metadata": SizeLimit(
        16 * _MiB, "dataset schema", "column names, units and descriptions: tens of KiB"
    ),
    "chunk": SizeLimit(
        4 * _GiB,
        "chunk file",
        "a chunk of at most 2^20 design-state rows of some 60 columns is under 1 GiB",
    ),
    "lookup index": SizeLimit(
        16 * _GiB,
        "lookup index",
        "an index of 10^8 rows: a few float64 columns per row, under 8 GiB",
    ),
    "objects": SizeLimit(
        64 * _MiB,
        "objects file (CSV)",
        "a row is a name, two numbers and a class, under 100 bytes: 10^5 objects are under 10 MiB",
    ),
    "record": SizeLimit(
        16 * _MiB,
        "result record",
        "a result directory's marker or report, a lock file: a few KiB of JSON",
    ),
    "kernel sources stamp": SizeLimit(
        1 * _MiB,
        "kernel sources stamp",
        "path, size and modification time of each kernel source: about 80 bytes per file",
    ),
}


def size_limit(limit: int | str) -> SizeLimit:
    """The :class:`SizeLimit` of a kind of :data:`SIZE_LIMITS`, or of a plain byte count."""
    if isinstance(limit, str):
        return SIZE_LIMITS[limit]
    return SizeLimit(int(limit), "file", "")


def read_bounded(path: str | Path, max_bytes: int | str) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    The file's kind and size are checked before it is read (by ``stat``) and again on the open
    file (it may have been replaced meanwhile); it is opened non-blocking, so a FIFO put in its
    place never blocks, and read no further than ``max_bytes + 1`` bytes.

    Parameters
    ----------
    path : str or Path
    max_bytes : int or str
        The limit, bytes, or the kind of file whose limit applies (a key of
        :data:`SIZE_LIMITS`, named in the messages).

    Raises
    ------
    BoundedReadError
        ``PATH: is a directory``, ``PATH: not a regular file (...)``, ``PATH: N bytes, more than
        the limit of M``.
    OSError
        As :func:`os.stat` and :func:`os.open` raise it (missing file, no permission).
    """
    path = Path(path)
    limit = size_limit(max_bytes)
    info = os.stat(path)
    _check_kind(path, info.st_mode, limit, info.st_size)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        info = os.fstat(fd)
        _check_kind(path, info.st_mode, limit, info.st_size)
        chunks, size = [], 0
        while size <= limit.bytes:
            chunk = os.read(fd, limit.bytes + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    finally:
        os.close(fd)
    if size > limit.bytes:  # it grew while read
        raise BoundedReadError(f"{path}: more than the limit of {_of(limit)}")
    return b"".join(chunks)


def check_file(path: str | Path, max_bytes: int | str) -> int:
    """Refuse ``path`` unless it is a regular file within its limit; its size, bytes.

    For a file that a library opens itself (a Parquet chunk, an ``.npz`` index): the same
    checks as :func:`read_bounded`, by ``stat``, before the library reads anything.

    Raises
    ------
    BoundedReadError, OSError
        As :func:`read_bounded`.
    """
    path = Path(path)
    info = os.stat(path)
    _check_kind(path, info.st_mode, size_limit(max_bytes), info.st_size)
    return info.st_size


def _of(limit: SizeLimit) -> str:
    return f"{limit.bytes}" if limit.what == "file" else f"{limit.bytes} for a {limit.what}"


def _check_kind(path: Path, mode: int, limit: SizeLimit, size: int) -> None:
    if stat.S_ISDIR(mode):
        raise BoundedReadError(f"{path}: is a directory, not a {limit.what}")
    if not stat.S_ISREG(mode):
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a device or socket"
        raise BoundedReadError(f"{path}: not a regular file ({kind})")
    if size > limit.bytes:
        raise BoundedReadError(f"{path}: {size} bytes, more than the limit of {_of(limit)}")


def read_json_bounded(path: str | Path, max_bytes: int | str, *, strict: bool = True) -> object:
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
