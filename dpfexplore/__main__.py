"""``python -m dpfexplore`` and the ``dpfexplore`` console script.

Ctrl-C while the command's modules load is one line and exit code 130, as it is everywhere later
(:func:`dpfexplore.cli.main`). Until :func:`run` installs its handler, Python's default one raises
``KeyboardInterrupt`` wherever the interpreter next checks for signals, with a traceback through
whatever frames are running then. So nothing runs in a ``dpfexplore`` frame before the handler but
the two module bodies: this one imports only :mod:`sys` and :mod:`_signal`, the C module behind
:mod:`signal` that the interpreter loads to install its own handler (importing either runs no
Python code; ``import signal`` would run ``signal.py`` and :mod:`enum`'s conversions first, a
window of about a millisecond, longer under load), and ``dpfexplore/__init__.py`` imports only an
already-loaded module without a from-list. What remains is a few microseconds of definitions.

A Ctrl-C inside a C extension's import can come out as an ``ImportError`` with no trace of it
(NumPy: "PyCapsule_Import could not import module 'datetime'"), so the handler records the signal
and the guard counts such an error as the interruption it is.
"""

import _signal
import sys

_SEEN: list[int] = []


def _record(signum, frame) -> None:
    _SEEN.append(signum)
    raise KeyboardInterrupt


def run() -> None:
    """Run the CLI with ``sys.argv`` and exit with its code."""
    previous = None
    try:
        # Inside the guard: a signal pending since start-up is raised as soon as a call returns.
        # ``previous`` is set only once it is read, so the handler is restored exactly when set.
        previous = _signal.getsignal(_signal.SIGINT)
        _signal.signal(_signal.SIGINT, _record)
        from dpfexplore.cli import main
    except (KeyboardInterrupt, ImportError) as exc:
        if isinstance(exc, ImportError) and not _SEEN:
            raise
        print("dpfexplore: interrupted", file=sys.stderr)
        sys.exit(130)
    finally:
        if previous is not None:
            _signal.signal(_signal.SIGINT, previous)
    code = main()
    # The command has finished and said what it had to: a Ctrl-C while the interpreter shuts
    # down would otherwise end the process by SIGINT with nothing said, whatever the command did.
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)
    sys.exit(code)


if __name__ == "__main__":
    run()
