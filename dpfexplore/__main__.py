"""``python -m dpfexplore`` and the ``dpfexplore`` console script.

The entry point imports nothing but :mod:`sys` before its guard, so that Ctrl-C while the
command's modules load is one line and exit code 130, as it is everywhere later
(:func:`dpfexplore.cli.main`). Only Python's own start-up, before any of this runs, can still
print a traceback.
"""

import sys


def run() -> None:
    """Run the CLI with ``sys.argv`` and exit with its code."""
    try:
        from dpfexplore.cli import main
    except KeyboardInterrupt:
        print("dpfexplore: interrupted", file=sys.stderr)
        sys.exit(130)
    sys.exit(main())


if __name__ == "__main__":
    run()
