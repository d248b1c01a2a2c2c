"""Command-line interface: ``dpfexplore <command> ...``.

Thin by design: each command module parses its arguments, calls the public API and returns an
exit code (0 success, 1 failure of the computation, 2 bad input). Command modules register
themselves through ``register(subparsers)``; :data:`COMMAND_MODULES` lists them.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

#: Modules under :mod:`dpfexplore.cli` that each add one or more subcommands.
COMMAND_MODULES = ("states", "sweep", "simulate", "simulate_leg", "resetmaps", "lookup", "bench")

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2


class UsageError(Exception):
    """Bad input from the user: printed as one line, exit code 2."""


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="dpfexplore",
        description=(
            "Batch design-space explorer for multistable Dome Phalanx Fingers. "
            "Units: mm, N, MPa, tonne, s; energy in N·mm, stiffness in N/mm."
        ),
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress at INFO level")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (``sys.exit(main())`` in the console script)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    try:
        return int(args.handler(args))
    except UsageError as exc:
        print(f"dpfexplore {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
