"""Chunk files committed through a manifest: written whole, recorded with a checksum, verified.

A chunked result directory (a finger sweep's dataset, a unit-cell sweep's ``chunks/``) commits
each chunk the same way:

1. the chunk's bytes are written to a temporary name (a leading ``.`` and
   :data:`~.files.TEMP_SUFFIX`, which readers skip), fsynced and renamed onto the chunk's
   deterministic name (:func:`commit_file`): a retried chunk overwrites, never duplicates;
2. the directory's manifest (:data:`MANIFEST`) is rewritten atomically, listing the chunk with
   its size and SHA-256. It is the commit record: a chunk file the manifest does not list does
   not exist for readers or for a resumed run;
3. every read checks the bytes it decodes against the record (:func:`verified_bytes`), and a
   resumed run checks every listed chunk before trusting it (:func:`verify_file`): a chunk
   deleted, truncated or edited after its commit is an error naming it, or is recomputed.

What a chunk holds and what else its manifest records belong to its writer
(:mod:`dpfexplore.sweep.storage.store`, :mod:`dpfexplore.unitcell.sweep_chunks`); this module
holds only the part they share. :class:`StoreError` is the error of a directory that cannot be
used as asked.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from .files import (
    TEMP_SUFFIX,
    BoundedReadError,
    atomic_write,
    check_file,
    file_sha256,
    read_bounded,
)

if TYPE_CHECKING:
    import pyarrow as pa

__all__ = [
    "MANIFEST",
    "Committed",
    "FileRecord",
    "StoreError",
    "commit_file",
    "read_file_buffer",
    "read_json",
    "remove_leftovers",
    "verified_bytes",
    "verify_file",
    "write_json",
]

#: File name of the commit record of a chunked directory.
MANIFEST = "_manifest.json"


class StoreError(Exception):
    """A result directory that cannot be used as asked (another job's, corrupt, not ours)."""


class Committed(Protocol):
    """What a manifest records of a committed file (a chunk record has at least these)."""

    @property
    def path(self) -> str:
        """Path relative to the directory of the manifest, POSIX separators."""

    @property
    def bytes(self) -> int:
        """File size."""

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the file's bytes."""


@dataclass(frozen=True)
class FileRecord:
    """A committed file: its path relative to the manifest's directory, size and SHA-256."""

    path: str
    bytes: int
    sha256: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {"path": self.path, "bytes": self.bytes, "sha256": self.sha256}


def commit_file(root: str | Path, relpath: str, data: bytes | memoryview) -> FileRecord:
    """Write ``root/relpath`` atomically (folders created) and return its record.

    Safe to run twice for the same file, even concurrently (a retried chunk): each writer has
    its own temporary file and the last rename wins. The manifest is not touched.
    """
    target = Path(root) / relpath
    target.parent.mkdir(parents=True, exist_ok=True)
    view = memoryview(data)
    digest = hashlib.sha256(view).hexdigest()
    atomic_write(target, view)
    return FileRecord(path=relpath, bytes=view.nbytes, sha256=digest)


def read_file_buffer(path: str | Path) -> pa.Buffer:
    """The whole file in memory that Arrow allocated (not a Python ``bytes``).

    Arrow's Parquet reader may release its input on one of its own threads after the read has
    returned. Were the input a Python object, that release would need the GIL, and at
    interpreter exit it can kill the process ("terminate called without an active exception",
    exit 134). Memory owned by Arrow is released without Python.

    Only a regular file within the limit of a chunk is read
    (:func:`~dpfexplore.io.files.check_file`): :class:`StoreError` naming it otherwise.
    """
    import pyarrow as pa

    try:
        check_file(path, "chunk")
    except BoundedReadError as exc:
        raise StoreError(f"chunk {exc}") from None
    with pa.OSFile(str(path)) as fh:
        return fh.read_buffer()


def verified_bytes(
    root: str | Path, record: Committed, *, verify: bool = True, remedy: str = ""
) -> pa.Buffer:
    """The bytes of a committed file, checked against its manifest record.

    Returned as an Arrow buffer (:func:`read_file_buffer`), ready for ``pa.BufferReader``.

    Parameters
    ----------
    root : str or Path
        The manifest's directory.
    record : Committed
        The file's record.
    verify : bool
        Check size and SHA-256 (one hashing pass over the bytes read).
    remedy : str
        What to do about a changed file, appended to the message (``"recompute it with ..."``).

    Raises
    ------
    StoreError
        Naming the chunk, if it is missing, or (``verify``) its size or SHA-256 differs from
        the record: it changed after it was committed.
    """
    path = Path(root) / record.path
    try:
        data = read_file_buffer(path)
    except FileNotFoundError:
        raise StoreError(f"chunk {path}: missing (it is in {MANIFEST})") from None
    if verify:
        problem = None
        if data.size != record.bytes:
            problem = f"size {data.size} != {record.bytes} bytes"
        elif hashlib.sha256(memoryview(data)).hexdigest() != record.sha256:
            problem = "SHA-256 differs from the manifest's"
        if problem is not None:
            tail = f"; {remedy}" if remedy else ""
            raise StoreError(
                f"chunk {path}: {problem}: the file changed after it was committed{tail}"
            )
    return data


def verify_file(root: str | Path, record: Committed, *, checksum: bool = True) -> str | None:
    """Why a committed file cannot be trusted any more, or None if it is intact.

    ``checksum=False`` checks presence and size only (no read).
    """
    path = Path(root) / record.path
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        return "missing"
    if size != record.bytes:
        return f"size {size} != {record.bytes} bytes"
    if checksum and file_sha256(path) != record.sha256:
        return "checksum mismatch"
    return None


def remove_leftovers(root: str | Path, folders: Iterable[str] = ()) -> list[Path]:
    """Delete temporary files of interrupted writes in ``root`` and its ``folders``.

    ``folders`` are glob patterns relative to ``root`` (``"N*"``). Returns what was removed.
    Call it only while no writer runs (before a run starts, after it ends, lock held).
    """
    root = Path(root)
    places = [root, *(p for pattern in folders for p in root.glob(pattern) if p.is_dir())]
    removed = []
    for place in places:
        for path in place.glob(f".*{TEMP_SUFFIX}"):
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed


def write_json(path: str | Path, data: Any, *, indent: int | None = 1) -> None:
    """Replace ``path`` with ``data`` as canonical JSON (sorted keys), atomically."""
    text = json.dumps(data, indent=indent, sort_keys=True) + "\n"
    atomic_write(path, text.encode())


def read_json(path: str | Path) -> dict[str, Any]:
    """A JSON object from ``path``.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    StoreError
        In one line naming the file, if it cannot be read or is not a JSON object; a special
        file or one over the limit of a manifest is not read
        (:func:`~dpfexplore.io.files.read_bounded`).
    """
    path = Path(path)
    try:
        text = read_bounded(path, "manifest").decode("utf-8")
    except FileNotFoundError:
        raise
    except BoundedReadError as exc:
        raise StoreError(str(exc)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise StoreError(f"{path}: cannot read ({exc})") from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise StoreError(f"{path}: not JSON ({exc})") from None
    if not isinstance(data, dict):
        raise StoreError(f"{path}: not a JSON object")
    return data
