"""``dpfexplore identify``: spring constants from unit-cell curves (MODEL.md §11).

* ``identify fit TABLE --out results/constants/NAME [--plot] [--allow-flagged] [--force]``
  fits the dome spring law to every curve of a CSV or Parquet table and selects closed forms
  for ``k_b``, ``alpha`` and ``tip_dis`` (grouped RFECV with ridge), saved as a constants set.
* ``identify report NAME`` prints a saved identification (``NAME``: a directory, or a name
  under results/constants).
* ``identify compare NAME [OTHER] --design DESIGN [--design ...] [--plot FILE.png]`` sets side
  by side on each design's units and on the whole finger (sequential states, tips, stiffness,
  reset times; ``OTHER`` defaults to the paper's closed forms); ``--plot`` draws the fingers'
  tips, stiffness and reset times under both sets, one column per design.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

from . import EXIT_OK, UsageError
from .support.inputs import design_argument, saved_path
from .support.output import (
    FIGURE_SUFFIXES,
    announce_compilation,
    json_text,
    output_path,
    save_figure,
)


def register(subparsers) -> None:
    """Add ``identify`` and its subcommands."""
    parser = subparsers.add_parser(
        "identify",
        help="spring constants from unit-cell curves: fit, report, compare constants sets",
        description=__doc__.split("\n\n", 1)[1],
    )
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    fit = sub.add_parser(
        "fit", help="fit the spring law per curve and select closed forms; save the set"
    )
    fit.add_argument("table", type=Path, help="CSV or Parquet table of unit-cell curves")
    fit.add_argument(
        "--out", type=Path, required=True, help="result directory, e.g. results/constants/NAME"
    )
    fit.add_argument("--name", default=None, help="name of the set (default: the --out folder)")
    fit.add_argument("--degree", type=int, default=3, help="largest power of pi1 and pi3")
    fit.add_argument(
        "--selector",
        choices=("rfecv", "lasso"),
        default="rfecv",
        help="whose support the set uses (both are scored on held-out geometries)",
    )
    fit.add_argument(
        "--max-rms", type=float, default=0.05, help="largest relative RMS residual of a fit"
    )
    fit.add_argument(
        "--method",
        choices=("states", "features", "least_squares"),
        default="states",
        help="per-curve fit: the law holding the curve's inverted rest, its initial slope and "
        "barrier balanced (default); the law matched to the initial slope, inverted rest and "
        "that rest's energy; or robust least squares over the curve",
    )
    fit.add_argument(
        "--allow-flagged", action="store_true", help="leave flagged curve fits out, not refuse"
    )
    fit.add_argument("--plot", action="store_true", help="also write selection.png")
    fit.add_argument("--force", action="store_true", help="replace --out if it holds a result")
    fit.add_argument("--json", action="store_true", help="print the report as JSON")
    fit.set_defaults(handler=_fit)
    report = sub.add_parser("report", help="print a saved identification")
    report.add_argument("name", help="directory, or a name under results/constants")
    report.add_argument("--json", action="store_true", help="print the report as JSON")
    report.set_defaults(handler=_report)
    compare = sub.add_parser(
        "compare", help="two constants sets on designs: units, states, tips, stiffness, resets"
    )
    compare.add_argument(
        "name",
        help="a saved identification (directory or name), a constants set file, 'paper' or a "
        "packaged set's name ('shell-extended')",
    )
    compare.add_argument("other", nargs="?", default=None, help="another (default: the paper's)")
    compare.add_argument(
        "--design",
        required=True,
        action="append",
        help="design file or example name (repeat for several): its units and the whole "
        "finger under both sets",
    )
    compare.add_argument("--json", action="store_true", help="print the rows as JSON")
    compare.add_argument(
        "--plot",
        metavar="FILE.png",
        default=None,
        help="draw each design's state tips, tip stiffness and reset times under both sets",
    )
    compare.set_defaults(handler=_compare)


def _load(name: str):
    """A saved identification, a constants set file, ``paper`` or a packaged set.

    Returns ``(set, report)``; the report is None for anything but a saved identification.
    """
    from ..identification.report import read_identification
    from ..model.constants_set import SAVED_DIR, find_constants_set

    path = saved_path(name, SAVED_DIR)
    try:
        if path.is_dir():
            return read_identification(path)
        return find_constants_set(name), None
    except ValueError as exc:
        raise UsageError(str(exc).splitlines()[0]) from None


def _fit(args: argparse.Namespace) -> int:
    from ..identification.curves import CurveError, read_curves
    from ..identification.identify import identify
    from ..identification.report import _report, save_identification
    from ..io.result_dirs import ResultError, check_output_dir
    from ..model.constants_set import ConstantsSetError

    try:
        check_output_dir(args.out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    if not 1 <= args.degree <= 5:
        raise UsageError(f"--degree {args.degree}: must be between 1 and 5")
    if not (math.isfinite(args.max_rms) and args.max_rms > 0.0):
        raise UsageError(f"--max-rms {args.max_rms}: need a finite relative RMS > 0")
    try:
        if args.method == "states":
            from ..identification.states import read_states_curves

            curves = read_states_curves(args.table)  # keeps first branches and zero-force states
        elif args.method == "features":
            from ..identification.features import read_feature_curves

            curves = read_feature_curves(args.table)  # keeps each curve's first branch
        else:
            curves = read_curves(args.table)
        result = identify(
            curves,
            name=args.name or args.out.name,
            degree=args.degree,
            selector=args.selector,
            max_relative_rms=args.max_rms,
            allow_flagged=args.allow_flagged,
            method=args.method,
        )
        save_identification(result, args.out, plot=args.plot, force=args.force)
    except (CurveError, ConstantsSetError, ResultError) as exc:
        raise UsageError(str(exc)) from None
    report = _report(result)
    if args.json:
        print(json_text(report))
    else:
        from ..identification.report import format_report

        print(format_report(report))
        print(f"saved to {args.out}")
    return EXIT_OK


def _report(args: argparse.Namespace) -> int:
    from ..identification.report import format_report

    constants, report = _load(args.name)
    if report is None:
        raise UsageError(
            f"{args.name}: a constants set ({constants.label}), not a saved identification "
            "(identify report reads the directory identify fit wrote)"
        )
    print(json_text(report) if args.json else format_report(report))
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    from ..identification.compare import compare_fingers, format_comparison
    from ..identification.report import compare_sets
    from ..model.constants_set import DEFAULT

    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    first, _ = _load(args.name)
    second = _load(args.other)[0] if args.other else DEFAULT
    if first.name == second.name:
        second = dataclasses.replace(second, name=f"{second.name} (2)")
    designs = [(text, design_argument(text)) for text in args.design]
    names = [first.name, second.name]
    announce_compilation("identify compare", ["states", "dynamics"])
    document = []
    drawn = []
    for text, design in designs:
        units = compare_sets([first, second], design.H, design.t, design.r_b, design.E)
        states, resets = compare_fingers([first, second], design)
        drawn.append((design.name or text, states, resets))
        document.append(
            {
                "design": design.name or text,
                "units": units.to_dict(orient="records"),
                "states": states.to_dict(orient="records"),
                "reset_times": resets.to_dict(orient="records"),
            }
        )
        if args.json:
            continue
        print("\n".join(format_comparison(design.name or text, names, units, states, resets)))
        print()
    if args.json:
        print(json_text(document))
    if plot is not None:
        from ..plotting.compare import plot_set_comparison

        figure = plot_set_comparison(drawn, [first.name, second.name])
        save_figure(figure, plot, dpi=130)
    return EXIT_OK
