"""Command-line interface: ``dpfexplore <command> ...``.

Thin by design: each command module parses its arguments, calls the public API and returns an
exit code (0 success, 1 failure of the computation, 2 bad input, 130 interrupted). Command
modules register themselves through ``register(subparsers)``; :data:`COMMAND_MODULES` lists
them, one module per command named after it (``sweep`` also holds ``query`` and
``plot-space``, ``finger.grasp`` also ``sort``), those about one finger in :mod:`.finger`;
:mod:`.support` holds what they share (one-line errors and tolerant streams, help screens,
naming a design or a constants set).

What every command gets from :func:`main`:

* bad input (:class:`UsageError`, or a ``ValueError``/``OSError`` a command turns into one) is
  one line on stderr and exit code 2, never a traceback;
* a write that fails for want of room or of a writable place (a full disk) is one line naming
  the file and exit code 1 (:func:`~.support.output.write_failure`); the writers of
  :mod:`dpfexplore.io` leave no partial file;
* an option value that starts with ``-`` (``--tau -2,-1,0,0.1``) reaches the option and its
  validation, instead of argparse's "expected one argument";
* Ctrl-C ends with one line and exit code 130 (``sweep`` says what was committed and how to
  resume);
* a reader that goes away (``dpfexplore query DIR --json | head``, ``design ... 2>&1 | head
  -1``) or a closed stream (``2>&-``) never changes what a command computes, writes or
  returns: output that cannot be written is dropped (:class:`~.support.output.TolerantStream`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import re
import signal
import sys
import threading
from collections.abc import Sequence

from .support.help import ArgumentParser
from .support.output import (
    SafeStreamHandler,
    TolerantStream,
    UsageError,
    discard,
    ensure_streams,
    error_line,
    write_failure,
)

#: Modules under :mod:`dpfexplore.cli` that each add one or more subcommands.
COMMAND_MODULES = (
    "finger.states",
    "finger.grasp",
    "sweep",
    "finger.simulate",
    "finger.simulate_leg",
    "finger.snap",
    "finger.resetmaps",
    "resetmodel",
    "surrogate",
    "lookup",
    "design",
    "identify",
    "unitcell",
    "validate",
    "explore",
    "bench",
)

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
#: Exit code of a command ended by Ctrl-C (128 + SIGINT, the shell's convention).
EXIT_INTERRUPTED = 130


def _version_text() -> str:
    import dpfexplore

    return f"dpfexplore {dpfexplore.__version__}"


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every registered subcommand."""
    parser = ArgumentParser(
        prog="dpfexplore",
        description=(
            "Batch design-space explorer for multistable Dome Phalanx Fingers. "
            "Units: mm, N, MPa, tonne, s; energy in N·mm, stiffness in N/mm."
        ),
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress at INFO level")
    parser.add_argument("--version", action="version", version=_version_text())
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(subparsers)
    return parser


#: A value that argparse would take for an option because it starts with ``-``: a negative
#: number or a list of them (``-2,-1,0,0.1``, ``-0.7``).
_DASH_VALUE = re.compile(r"^-\.?\d")


def _single_value_options(parser: argparse.ArgumentParser) -> set[str]:
    """Option strings, over the parser and its subcommands, that take exactly one value."""
    options: set[str] = set()
    parsers = [parser]
    while parsers:
        current = parsers.pop()
        for action in current._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers.extend(action.choices.values())
            elif action.option_strings and action.nargs is None:
                options.update(action.option_strings)
    return options


def attach_dash_values(argv: Sequence[str], parser: argparse.ArgumentParser) -> list[str]:
    """Write ``--opt -2,-1`` as ``--opt=-2,-1`` for options that take one value.

    argparse reads a token that starts with ``-`` and is not a plain negative number as an
    option, so ``--tau -2,-1,0,0.1`` failed with "expected one argument" before the value
    could be checked. Attached, the value reaches its validation and its real message.
    """
    options = _single_value_options(parser)
    out: list[str] = []
    for token in argv:
        if out and out[-1] in options and _DASH_VALUE.match(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (``sys.exit(main())`` in the console script)."""
    ensure_streams()
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = TolerantStream(sys.stdout), TolerantStream(sys.stderr)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, _on_ctrl_c) if main_thread else None
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _redeliver_ctrl_c(previous_hook)
    _CTRL_C["seen"] = False
    try:
        return _run(argv)
    finally:
        sys.unraisablehook = previous_hook
        if main_thread and previous is not None:  # None: a handler installed outside Python
            signal.signal(signal.SIGINT, previous)
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        sys.stdout, sys.stderr = streams


def _run(argv: Sequence[str] | None) -> int:
    try:  # importing the commands takes a moment: Ctrl-C there is one line too
        parser = build_parser()
        argv = list(sys.argv[1:] if argv is None else argv)
        args = parser.parse_args(attach_dash_values(argv, parser))
    except (KeyboardInterrupt, ImportError) as exc:
        if not _caused_by_ctrl_c(exc):
            raise
        error_line("dpfexplore: interrupted")
        return EXIT_INTERRUPTED
    handler = SafeStreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(asctime)s %(name)s %(levelname)s %(message)s"))
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, handlers=[handler])
    # The solvers announce a first compilation once the inputs are checked (solvers.compilation),
    # and reading a constants set that failed validation announces its figures
    # (model.constants_set): each shown once, as the command's own line, like every notice.
    notice_logs = [logging.getLogger(name) for name in NOTICE_LOGGERS]
    notices = SafeStreamHandler(sys.stderr)
    notices.setFormatter(logging.Formatter(f"dpfexplore {args.command}: %(message)s"))
    notices.addFilter(_OncePerCommand())
    for log in notice_logs:
        log.addHandler(notices)
        log.propagate = False
    try:
        return _handle(args)
    finally:
        for log in notice_logs:
            log.removeHandler(notices)
            log.propagate = True


#: Loggers whose records a command shows as its own lines (``dpfexplore COMMAND: ...``).
NOTICE_LOGGERS = ("dpfexplore.compile", "dpfexplore.validation")


class _OncePerCommand(logging.Filter):
    """Let each notice through once per command (a set read twice is announced once)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message in self.seen:
            return False
        self.seen.add(message)
        return True


def _handle(args: argparse.Namespace) -> int:
    try:
        code = int(args.handler(args))
        sys.stdout.flush()
        return code
    except UsageError as exc:
        error_line(f"dpfexplore {args.command}: error: {exc}")
        return EXIT_USAGE
    except BrokenPipeError:  # the reader of stdout went away (``| head``): nothing more to say
        discard("stdout")
        return EXIT_OK
    except KeyboardInterrupt:
        error_line(f"dpfexplore {args.command}: interrupted")
        return EXIT_INTERRUPTED
    except ImportError as exc:
        if not _caused_by_ctrl_c(exc):
            raise
        error_line(f"dpfexplore {args.command}: interrupted")
        return EXIT_INTERRUPTED
    except OSError as exc:  # a full disk or a read-only place while writing: one line
        line = write_failure(exc)
        if line is None:
            raise
        error_line(f"dpfexplore {args.command}: error: {line}")
        return EXIT_FAILURE


#: Set once Ctrl-C arrived during this process's command (see :func:`_caused_by_ctrl_c`).
_CTRL_C = {"seen": False}


def _on_ctrl_c(signum: int, frame: object) -> None:
    _CTRL_C["seen"] = True
    raise KeyboardInterrupt


def _redeliver_ctrl_c(previous):
    """An unraisable-exception hook that re-delivers a Ctrl-C swallowed by a C callback.

    Ctrl-C while Numba compiles can land inside an llvmlite ctypes callback, where Python only
    prints "Exception ignored ..." with a traceback and carries on compiling. Re-raising the
    signal lets it arrive where it can stop the command (one line, exit code 130).
    """

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            # not from here: a signal raised inside the hook would land in the hook itself
            threading.Timer(0.05, signal.raise_signal, args=(signal.SIGINT,)).start()
            return
        previous(unraisable)

    return hook


def _caused_by_ctrl_c(exc: BaseException) -> bool:
    """Whether Ctrl-C is behind ``exc``.

    A Ctrl-C inside a C extension's import can come out as an ``ImportError`` that carries no
    trace of it (NumPy: "PyCapsule_Import could not import module 'datetime'"), so the signal
    handler's record decides, not the exception chain alone.
    """
    return isinstance(exc, KeyboardInterrupt) or _CTRL_C["seen"]


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
