"""Output helpers of the CLI: one-line errors, streams whose reader went away, output files."""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path


class UsageError(Exception):
    """Bad input from the user: printed as one line, exit code 2."""


def discard(stream_name: str) -> None:
    """Point ``sys.<stream_name>`` (and its file descriptor) at /dev/null.

    Called once its reader has gone: later writes, and the flush at interpreter exit, then
    succeed silently instead of raising ``BrokenPipeError``.
    """
    stream = getattr(sys, stream_name)
    try:
        fd = stream.fileno()
    except (OSError, ValueError):
        fd = None
    devnull = os.open(os.devnull, os.O_WRONLY)
    if fd is not None:
        os.dup2(devnull, fd)
        os.close(devnull)
        setattr(sys, stream_name, os.fdopen(fd, "w", closefd=False))
    else:
        setattr(sys, stream_name, os.fdopen(devnull, "w"))


def error_line(text: str) -> None:
    """Write one line to stderr; a closed stderr is silently dropped (never stops a command)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (BrokenPipeError, ValueError, OSError):
        discard("stderr")


class SafeStreamHandler(logging.StreamHandler):
    """Logging to stderr that drops records once stderr is closed (a broken pipe)."""

    def handleError(self, record: logging.LogRecord) -> None:
        exc = sys.exc_info()[1]
        if isinstance(exc, (BrokenPipeError, OSError, ValueError)):
            discard("stderr")
            self.setStream(sys.stderr)
            return
        super().handleError(record)


def output_path(path: str | Path) -> Path:
    """``path`` as a Path whose folder exists.

    Every command that writes a file creates its folder, as ``sweep --out`` creates its
    directory (``states --plot``, ``simulate --plot``, ``query --csv``, ``plot-space --out``).

    Raises
    ------
    UsageError
        If ``path`` is a directory or its folder cannot be created.
    """
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{path}: is a directory; give a file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = exc.strerror or exc
        raise UsageError(f"{path.parent}: cannot create the folder ({reason})") from None
    return path


def fitted_range_line(note: str) -> str:
    """The table outputs' line for a design outside the closed forms' fitted ranges."""
    return (
        f"note: outside the range the closed forms were fitted on ({note}); the spring "
        "constants are extrapolated"
    )
