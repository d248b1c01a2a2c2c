"""``dpfexplore explore DATASET``: the design-space explorer, a local page over a sweep dataset.

Exit codes: 0 the server was stopped by Ctrl-C after serving (one line); 2 bad input (a path that
is not a complete, intact sweep dataset with tip columns, a port in use, another constants set):
one line naming the path or the port, and no server is started.
"""

from __future__ import annotations

import argparse
import sys
import webbrowser
from pathlib import Path

from . import EXIT_OK, UsageError
from .support.inputs import add_constants_option, constants_argument


def register(subparsers) -> None:
    """Add the ``explore`` subcommand."""
    parser = subparsers.add_parser(
        "explore",
        help="explore a sweep dataset in the browser: tips on a map, filters, verified designs",
        description="Serve a local page (127.0.0.1 only) over a sweep dataset: the tips of all "
        "its rows on a map rasterized on the server and coloured by a column, filters with "
        "counts, and a click (or a typed target) that returns the nearest designs under the "
        "filters, refined and re-solved by the exact model, each drawn in its states and "
        "downloadable as a design TOML. Needs the explore extra: pip install "
        "'dpfexplore[explore]'. Stop it with Ctrl-C.",
    )
    parser.add_argument("dataset", type=Path, help="sweep dataset directory")
    parser.add_argument(
        "--port", type=int, default=None, help="port on 127.0.0.1 (default: a free port)"
    )
    parser.add_argument(
        "--no-browser", action="store_true", help="print the address, do not open a browser"
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Check the port and the dataset, then serve until Ctrl-C."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise UsageError("the explorer needs Bokeh: pip install 'dpfexplore[explore]'") from None
    from ..explore.data import DatasetError, load_dataset
    from ..explore.server import PortError, check_port, start_server

    constants = constants_argument(args.constants)
    try:
        check_port(args.port)  # before the dataset is read: nothing is loaded for a busy port
        data = load_dataset(args.dataset, constants=constants)
        running = start_server(data, port=args.port)
    except (DatasetError, PortError) as exc:
        raise UsageError(str(exc)) from None
    except ValueError as exc:  # the lookup index cannot be built (no ok rows, ...)
        raise UsageError(f"{args.dataset}: {exc}") from None
    print(
        f"dpfexplore explore: {len(data):,} rows of {args.dataset} at {running.url} (Ctrl-C stops)",
        flush=True,
    )
    if not args.no_browser:
        webbrowser.open_new_tab(running.url)
    try:
        running.server.io_loop.start()
    except KeyboardInterrupt:
        running.server.stop()
        print(f"dpfexplore explore: stopped ({running.url})", file=sys.stderr, flush=True)
    return EXIT_OK
