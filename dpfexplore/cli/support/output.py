"""Output helpers of the CLI: one-line errors, streams whose reader went away, output files."""

from __future__ import annotations

import errno
import logging
import os
import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

from ...model.formatting import json_text  # noqa: F401  (re-exported for the commands)


class UsageError(Exception):
    """Bad input from the user: printed as one line, exit code 2."""


def _to_devnull(stream: TextIO | None) -> TextIO:
    """A stream on ``stream``'s descriptor after pointing that descriptor at /dev/null.

    Used once a stream's reader has gone: later writes, and the flush at interpreter exit, then
    succeed silently instead of raising ``BrokenPipeError`` (and exit code 120).
    """
    try:
        fd = stream.fileno() if stream is not None else None
    except (OSError, ValueError, AttributeError):
        fd = None
    devnull = os.open(os.devnull, os.O_WRONLY)
    if fd is None:
        return os.fdopen(devnull, "w")
    os.dup2(devnull, fd)
    os.close(devnull)
    return os.fdopen(fd, "w", closefd=False)


def discard(stream_name: str) -> None:
    """Point ``sys.<stream_name>`` (and its file descriptor) at /dev/null."""
    setattr(sys, stream_name, _to_devnull(getattr(sys, stream_name)))


def ensure_streams() -> None:
    """Give a closed standard stream (``2>&-``, ``>&-``) a /dev/null to write to.

    Python sets ``sys.stderr`` to None when descriptor 2 is closed at start-up, and a command
    then died on its first message with exit code 1 and nothing said. Writing into nothing is
    what the user asked for; the computation and its exit code must not change.
    """
    for number, name in ((1, "stdout"), (2, "stderr")):
        stream = getattr(sys, name)
        try:
            os.fstat(number)
            usable = stream is not None
        except OSError:
            usable = False
        if not usable:
            devnull = os.open(os.devnull, os.O_WRONLY)
            if devnull != number:
                os.dup2(devnull, number)
                os.close(devnull)
            setattr(sys, name, os.fdopen(number, "w", closefd=False))


class TolerantStream:
    """A standard stream whose lost reader is never the command's problem.

    A reader that goes away (``dpfexplore design ... 2>&1 | head -1``) must not stop the
    command at its next progress line (a ``BrokenPipeError``) with nothing written. Writes that
    fail because the reader went away are dropped (the descriptor is pointed at /dev/null, see
    :func:`discard`); everything else is the wrapped stream's.
    """

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        """Write ``text``; dropped (and counted as written) if the reader has gone."""
        try:
            return self._stream.write(text)
        except (BrokenPipeError, OSError, ValueError):
            self._stream = _to_devnull(self._stream)
            return len(text)

    def flush(self) -> None:
        """Flush; a reader that has gone is not an error."""
        try:
            self._stream.flush()
        except (BrokenPipeError, OSError, ValueError):
            self._stream = _to_devnull(self._stream)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def error_line(text: str) -> None:
    """Write one line to stderr; a closed stderr is silently dropped (never stops a command)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (BrokenPipeError, ValueError, OSError):
        discard("stderr")


class SafeStreamHandler(logging.StreamHandler):
    """Logging to stderr that drops records once stderr is closed (a broken pipe)."""

    def handleError(self, record: logging.LogRecord) -> None:
        """Drop the record when stderr is gone; report anything else as logging does."""
        exc = sys.exc_info()[1]
        if isinstance(exc, (BrokenPipeError, OSError, ValueError)):
            discard("stderr")
            self.setStream(sys.stderr)
            return
        super().handleError(record)


#: File types a ``--plot`` may name (what matplotlib writes from the suffix).
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def output_path(path: str | Path, option: str, *, suffixes: tuple[str, ...] = ()) -> Path:
    """``path`` as a Path whose folder exists, checked before the command does any work.

    Every command that writes a file creates its folder, as ``sweep --out`` creates its
    directory (``states --plot``, ``simulate --plot``, ``snap --plot``, ``lookup --plot``,
    ``query --csv``, ``plot-space --out``, ``reset-model fit --out``).

    Parameters
    ----------
    path : str or Path
        The file the user named.
    option : str
        The option it came from (``"--plot"``), named in every message.
    suffixes : tuple of str, optional
        Accepted file suffixes (e.g. :data:`FIGURE_SUFFIXES`): a figure path without one would
        be written as ``PATH.png`` by matplotlib, a file the user did not name.

    Raises
    ------
    UsageError
        If ``path`` is empty or a directory, has another suffix, or its folder cannot be
        created.
    """
    if not str(path).strip():
        raise UsageError(f"{option}: empty file name")
    path = Path(path)
    if path.is_dir() or str(path).endswith(("/", os.sep)):
        raise UsageError(f"{option} {path}: is a directory; give a file name")
    if suffixes and path.suffix.lower() not in suffixes:
        raise UsageError(f"{option} {path}: give a file name ending in {', '.join(suffixes)}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = exc.strerror or exc
        raise UsageError(
            f"{option} {path}: cannot create the folder {path.parent} ({reason})"
        ) from None
    return path


def refuse_overwrite(path: Path, option: str, force: bool) -> Path:
    """``path``, refused when it exists and ``force`` is not given: no file replaced silently.

    The rule of ``design --out`` and ``lookup --write`` for result directories
    (:func:`dpfexplore.io.result_dirs.check_output_dir`), for single files
    (``unitcell curve --out/--plot``, ``bench NAME --save``); checked before any work.

    Raises
    ------
    UsageError
        Naming the option and the file, and ``--force``.
    """
    if path.exists() and not force:
        raise UsageError(f"{option} {path}: the file exists; use --force to replace it")
    return path


#: ``errno`` of a write that failed for want of room or of a writable place: reported as one
#: line by every command (:func:`write_failure`), never as a traceback.
WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})
#: The temporary names of :mod:`dpfexplore.io` (``.NAME.PID-ID.tmp``, a staging or set-aside
#: directory ``.NAME.staging-PID-ID``): a message names the file the user asked for.
_TEMP_NAME = re.compile(r"^\.(?P<name>.+?)\.(?:\d+-[0-9a-f]+\.tmp|staging-\d+-[0-9a-f]+)$")


def shown_path(filename: str | os.PathLike) -> str:
    """``filename`` as the user named it: temporary and staging names mapped to their target."""
    parts = []
    for part in Path(filename).parts:
        match = _TEMP_NAME.match(part)
        parts.append(match.group("name") if match else part)
    return str(Path(*parts)) if parts else str(filename)


def save_figure(figure, path: str | os.PathLike, **options) -> None:
    """Save a Matplotlib ``figure`` to ``path`` whole or not at all (any savefig ``options``).

    Written aside and renamed into place (:func:`dpfexplore.io.files.atomic_writer`): a full disk
    or an interruption leaves the previous file, or none, never part of a figure. The format is
    the file's suffix.
    """
    from ...io.files import atomic_writer

    path = Path(path)
    with _naming(path), atomic_writer(path) as handle:
        figure.savefig(handle, format=path.suffix[1:].lower() or None, **options)


def save_table(frame, path: str | os.PathLike) -> None:
    """Write a pandas ``frame`` to ``path`` (``.csv``, else Parquet) whole or not at all."""
    from ...io.files import atomic_writer

    path = Path(path)
    with _naming(path), atomic_writer(path) as handle:
        if path.suffix.lower() == ".csv":
            handle.write(frame.to_csv(index=False).encode())
        else:
            frame.to_parquet(handle, index=False)


@contextmanager
def _naming(path: Path) -> Iterator[None]:
    """An ``OSError`` raised inside that names no file is raised again naming ``path``."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise


def write_failure(exc: OSError) -> str | None:
    """One line for an ``OSError`` of writing (a full disk, a quota, a read-only place).

    Also for a TOML file that did not read back as written
    (:class:`~dpfexplore.io.toml_write.TomlWriteError`). None for any other ``OSError``. Every
    writer of :mod:`dpfexplore.io` builds a file or a
    result directory aside and renames it into place, so a failed write leaves the previous
    file, or nothing, where the user looks.
    """
    from ...io.toml_write import TomlWriteError

    if isinstance(exc, TomlWriteError):
        return f"cannot write {shown_path(exc.filename)}: {exc.strerror}"
    if exc.errno not in WRITE_ERRNOS:
        return None
    reason = exc.strerror or os.strerror(exc.errno)
    where = f" {shown_path(exc.filename)}" if exc.filename is not None else ""
    return f"cannot write{where}: {reason}; nothing was written there"


def announce_compilation(command: str, groups: list[str]) -> None:
    """Say in one line that ``command`` compiles kernels first (nothing when they are cached).

    The line and the stages of the compilation that follow it (``compiling 1/2: ...``) go to
    the command's progress display on standard error
    (:class:`dpfexplore.io.progress.Progress`), the sweep's and design's format.
    """
    from ...io.progress import Progress, active
    from ...solvers.compilation import compile_notice

    display = active() or Progress(command.split()[0])
    notice = compile_notice(groups, display=display)
    if notice:
        display.note(notice)


def fitted_range_line(note: str) -> str:
    """The table outputs' line for a design outside the closed forms' fitted ranges."""
    return (
        f"note: outside the range the closed forms were fitted on ({note}); the spring "
        "constants are extrapolated"
    )
