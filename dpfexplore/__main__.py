"""``python -m dpfexplore`` and the ``dpfexplore`` console script.

The entry point imports nothing but :mod:`sys` and :mod:`signal` before its guard, so that
Ctrl-C while the command's modules load is one line and exit code 130, as it is everywhere
later (:func:`dpfexplore.cli.main`). A Ctrl-C inside a C extension's import can come out as an
``ImportError`` with no trace of it (NumPy: "PyCapsule_Import could not import module
'datetime'"), so the guard records the signal and counts such an error as the interruption it
is. Only Python's own start-up, before any of this runs, can still print a traceback.
"""

import signal
import sys

_SEEN: list[int] = []


def _record(signum, frame) -> None:
    _SEEN.append(signum)
    raise KeyboardInterrupt


def run() -> None:
    """Run the CLI with ``sys.argv`` and exit with its code."""
    previous = signal.signal(signal.SIGINT, _record)
    try:
        from dpfexplore.cli import main
    except (KeyboardInterrupt, ImportError) as exc:
        if isinstance(exc, ImportError) and not _SEEN:
            raise
        print("dpfexplore: interrupted", file=sys.stderr)
        sys.exit(130)
    finally:
        signal.signal(signal.SIGINT, previous)
    code = main()
    # The command has finished and said what it had to: a Ctrl-C while the interpreter shuts
    # down would otherwise end the process by SIGINT with nothing said, whatever the command did.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.exit(code)


if __name__ == "__main__":
    run()
