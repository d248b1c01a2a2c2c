"""One writer at a time per directory: an exclusive lock file held for the life of a run.

Two sweeps (of fingers or of unit cells) writing one directory would both compute everything,
and a resumed run started beside a running one deletes its uncommitted chunk files; two commands
writing one result directory would mix their files. So :func:`sweep_lock`
creates ``DIR/.dpfexplore-lock`` with ``O_CREAT | O_EXCL`` (atomic on local filesystems and on
NFS v3 and later) before it looks at the directory, and removes it when the sweep ends, whatever
the way it ends (return, exception, Ctrl-C). The file holds the holder's host, pid, process
start time and command line, so a refusal names the holder.

A lock left by a process that died without removing it (``kill -9``, a power cut) is *stale*:
its host is this host and its pid is not alive, or is alive but started at another time (a
recycled pid). A stale lock is taken over (with a warning); one held on another host cannot be
checked from here and is never taken over: the message says to remove the file if that process
is gone. Taking over is itself atomic: the stale file is renamed away first, and only one of
several processes that saw it stale can do that.

The lock file starts with a dot, so Parquet readers (``pandas.read_parquet(DIR)``) skip it.
"""

from __future__ import annotations

import json
import logging
import os
import socket
import sys
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .commits import StoreError
from .files import read_bounded

__all__ = ["LOCK_NAME", "LockHeld", "file_lock", "read_lock", "remove_if_empty", "sweep_lock"]

LOCK_NAME = ".dpfexplore-lock"

logger = logging.getLogger(__name__)


class LockHeld(StoreError):
    """Another live process holds the sweep directory (one-line message naming it)."""


def _process_start(pid: int) -> float | None:
    """Start time of process ``pid`` (s since the epoch), None if it does not exist."""
    import psutil

    try:
        return float(psutil.Process(pid).create_time())
    except (psutil.NoSuchProcess, psutil.ZombieProcess):
        return None
    except psutil.Error:  # AccessDenied: it exists, we just may not look
        return -1.0


def _holder() -> dict:
    return {
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "started": _process_start(os.getpid()),
        "since": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": " ".join(sys.argv)[:500],
    }


def read_lock(out: str | Path) -> dict | None:
    """The holder recorded in ``out``'s lock file, None if there is none ({} if unreadable)."""
    return _read_holder(Path(out) / LOCK_NAME)


def _read_holder(path: Path) -> dict | None:
    try:
        text = read_bounded(path, "record").decode("utf-8")
    except FileNotFoundError:
        return None
    except (OSError, ValueError):  # a special file, too large, not text: unreadable
        return {}
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        return {}
    return data if isinstance(data, dict) else {}


def _is_stale(holder: dict) -> bool:
    """Whether the recorded holder is certainly gone (only decidable on this host)."""
    if holder.get("host") != socket.gethostname():
        return False
    pid = holder.get("pid")
    if not isinstance(pid, int):
        return True  # unreadable or half-written by a process killed while writing it
    started = _process_start(pid)
    if started is None:
        return True
    recorded = holder.get("started")
    # A live pid that started at another time is a recycled pid, not the holder.
    return started > 0 and isinstance(recorded, (int, float)) and abs(started - recorded) > 1.0


def describe(holder: dict) -> str:
    """``pid 123 on host (since ...: command)`` for messages."""
    if not holder:
        return "an unreadable lock"
    text = f"pid {holder.get('pid')} on {holder.get('host')}"
    if holder.get("since"):
        text += f" since {holder['since']}"
    if holder.get("command"):
        text += f" ({holder['command']})"
    return text


def _try_create(path: Path, content: bytes) -> bool:
    try:
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    try:
        try:
            os.write(fd, content)
            os.fsync(fd)
        finally:
            os.close(fd)
    except BaseException as exc:  # a full disk (or Ctrl-C): no half-written lock left behind
        path.unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.filename is None:
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    return True


#: Age (s) after which an empty or unreadable lock file is stale: a writer killed between
#: creating the file and writing its holder leaves one, and nothing would ever remove it.
HALF_WRITTEN_AGE = 2.0


def _half_written_and_old(path: Path) -> bool:
    try:
        return time.time() - path.stat().st_mtime > HALF_WRITTEN_AGE
    except FileNotFoundError:
        return False


def acquire_file(path: Path, busy: str) -> dict:
    """Take the lock file ``path``; ``busy`` starts the refusal message. Returns our holder.

    Raises
    ------
    LockHeld
        If a live process (or a process on another host) holds it.
    """
    me = _holder()
    content = json.dumps(me, indent=1).encode()
    for _ in range(20):
        if _try_create(path, content):
            return me
        holder = _read_holder(path)
        if holder is None:
            continue  # released between our attempt and our look: try again
        if not holder:
            # Unreadable: perhaps being written this instant. Give the writer a moment.
            time.sleep(0.05)
            holder = _read_holder(path)
            if holder is None:
                continue
        stale = _is_stale(holder) if holder else _half_written_and_old(path)
        if not stale:
            where = (
                ""
                if holder.get("host") == me["host"]
                else (f"; if that process is gone, remove {path}")
            )
            raise LockHeld(f"{busy}: {describe(holder)}{where}")
        # Stale: rename it away (only one contender succeeds), then create ours.
        # Named after this lock file, so two locks in one folder never share aside names.
        aside = path.with_name(f"{path.name}.stale-{uuid.uuid4().hex[:8]}")
        try:
            os.rename(path, aside)
        except FileNotFoundError:
            continue
        aside.unlink(missing_ok=True)
        logger.warning("took over a stale lock %s (%s)", path, describe(holder))
    raise LockHeld(f"{busy}: could not take the lock {path} (contended)")


def release_file(path: Path, me: dict) -> None:
    """Remove the lock file ``path`` if it is still ours."""
    holder = _read_holder(path)
    if holder and holder.get("pid") == me["pid"] and holder.get("host") == me["host"]:
        path.unlink(missing_ok=True)


@contextmanager
def file_lock(path: str | Path, busy: str) -> Iterator[dict]:
    """Hold the lock file ``path`` for the ``with`` block (any writer, not only sweeps).

    Parameters
    ----------
    path : str or Path
        The lock file; its folder must exist. Created with ``O_CREAT | O_EXCL``, removed when
        the block ends, however it ends.
    busy : str
        Start of the one-line refusal, e.g. ``"--out DIR: another command is writing it"``.

    Yields
    ------
    dict
        Our holder record (host, pid, process start time, command).

    Raises
    ------
    LockHeld
        If a live process (or a process on another host) holds it; a stale lock (dead pid on
        this host, or empty and older than :data:`HALF_WRITTEN_AGE` s) is taken over.
    """
    path = Path(path)
    me = acquire_file(path, busy)
    try:
        yield me
    finally:
        release_file(path, me)


@contextmanager
def sweep_lock(out: str | Path) -> Iterator[dict]:
    """Hold the lock of sweep directory ``out`` for the ``with`` block (see the module doc)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with file_lock(out / LOCK_NAME, f"--out {out}: another sweep is using this directory") as me:
        yield me


def remove_if_empty(out: str | Path) -> None:
    """Remove directory ``out`` if it holds nothing (the lock's directory of a refused sweep)."""
    try:
        Path(out).rmdir()
    except OSError:
        pass
