"""``dpfexplore lookup DATASET --target X,Y``: designs of a sweep dataset that reach a target.

Exit codes: 0 candidates reported (with ``--refine``: the target was met); 1 with ``--refine``
when no candidate meets the target; 2 bad input. Every candidate is labelled ``ok`` only when it
meets the target to ``--tol`` (``not_met`` otherwise, with a note), refined or not.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..io.progress import Progress
from . import EXIT_FAILURE, EXIT_OK, UsageError
from .support.inputs import add_constants_option, constants_argument
from .support.output import FIGURE_SUFFIXES, json_text, output_path, save_figure


def register(subparsers) -> None:
    """Add the ``lookup`` subcommand."""
    parser = subparsers.add_parser(
        "lookup",
        help="find designs of a sweep dataset whose tip (or other outputs) reach a target",
        description="Nearest rows of a sweep dataset to a target (tip position in mm by "
        "default), optionally refined with the exact model until the target is met; every "
        "reported design is re-solved by the exact model. The index is kept beside the dataset "
        "(DATASET/_lookup-<columns>.npz) and rebuilt when the dataset changes.",
    )
    parser.add_argument("dataset", type=Path, help="sweep dataset directory")
    parser.add_argument(
        "--target",
        required=True,
        help="target values, comma-separated, one per column (e.g. 25,40 mm; "
        "a negative first value as --target=-5,30)",
    )
    parser.add_argument(
        "--columns", default="tip_x,tip_y", help="indexed output columns (default tip_x,tip_y)"
    )
    parser.add_argument(
        "--scales",
        help="scale of each column in its unit (default 1 each): distances are "
        "Euclidean in value/scale, e.g. --columns tip_x,tip_y,stiffness "
        "--scales 1,1,0.01",
    )
    parser.add_argument(
        "--state",
        help="only this state: a bit string (unit 1 first, e.g. 11110) or "
        "all-inverted (default: any state in the dataset)",
    )
    parser.add_argument(
        "--n-units", metavar="N", help="only these numbers of units: N, LOW..HIGH or N,N,..."
    )
    parser.add_argument("--where", help='dataset row filter, e.g. "stiffness > 0.05 and t < 0.8"')
    parser.add_argument("--k", type=int, default=10, help="number of candidates (default 10)")
    parser.add_argument(
        "--refine",
        action="store_true",
        help="polish each candidate with the exact model until the target is met",
    )
    parser.add_argument(
        "--tol",
        type=float,
        default=1e-6,
        help="refinement tolerance (default 1e-6, mm for the tip)",
    )
    parser.add_argument(
        "--constraints",
        nargs="+",
        metavar="KEY=VALUE",
        default=[],
        help="refinement constraints inside the job's box: "
        "heights=free|ascending|descending, ordered_units=1-4, tied=5,6, "
        "shared=U_L,U_sep, H|U_L|U_sep|t|t_lim=LOW:HIGH or =VALUE",
    )
    parser.add_argument(
        "--no-rebuild", action="store_true", help="refuse a stale index instead of rebuilding it"
    )
    parser.add_argument(
        "--no-verify",
        action="store_true",
        help="read chunks without checking their SHA-256 against the manifest",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument(
        "--plot",
        metavar="FILE.png",
        type=Path,
        help="draw the reachable tip region per N with the target and designs",
    )
    parser.add_argument(
        "--write",
        metavar="DIR",
        type=Path,
        help="save each design as DIR/candidate-NN.toml (read by dpfexplore states); DIR is "
        "written whole, and replaced only with --force",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace --write DIR when it holds an earlier result"
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


def _floats(text: str, option: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"{option} {text!r}: give comma-separated numbers") from None


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore lookup``."""
    from ..io.commits import StoreError
    from ..io.result_dirs import ResultError, check_output_dir
    from ..lookup.files import write_designs
    from ..lookup.index import StaleIndexError
    from ..lookup.polish import parse_constraints
    from ..lookup.query import lookup, parse_n_units

    try:  # output paths before the work
        if args.write:
            check_output_dir(args.write, option="--write", force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    columns = [c.strip() for c in args.columns.split(",") if c.strip()]
    target = _floats(args.target, "--target")
    if len(target) != len(columns):
        raise UsageError(
            f"--target {args.target}: {len(target)} values for {len(columns)} columns "
            f"({', '.join(columns)})"
        )
    scales = _floats(args.scales, "--scales") if args.scales else None
    try:
        n_units = parse_n_units(args.n_units) if args.n_units else None
        constraints = parse_constraints(args.constraints)
        with Progress("lookup", boundaries=False) as display:
            display.stage("searching, re-solving and refining" if args.refine else "searching")
            result = lookup(
                args.dataset,
                target,
                columns=columns,
                scales=scales,
                state=args.state,
                n_units=n_units,
                where=args.where,
                k=args.k,
                refine=args.refine,
                constraints=constraints,
                tol=args.tol,
                rebuild=not args.no_rebuild,
                verify=not args.no_verify,
                constants=constants_argument(args.constants),
            )
    except (StoreError, StaleIndexError, ValueError) as exc:
        raise UsageError(str(exc).splitlines()[0]) from None
    except KeyError as exc:  # read_results names an unknown --where column this way
        raise UsageError(str(exc.args[0])) from None
    try:
        written = write_designs(result, args.write, force=args.force) if args.write else []
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    if args.json:
        record = result.to_dict()
        if written:
            record["written"] = [str(p) for p in written]
        print(json_text(record))
    else:
        _print(result, written)
    if plot is not None:
        _plot(result, plot)
    if result.refined and not result.reachable:
        # a plain lookup's job is the nearest designs, labelled met or not_met; --refine asks
        # for the target itself, so missing it is a failure
        return EXIT_FAILURE
    return EXIT_OK


def _print(result, written) -> None:
    target = ", ".join(f"{c} = {v:g}" for c, v in zip(result.columns, result.target, strict=True))
    origin = result.index_origin
    index = (
        f"index of {result.index_rows} rows {origin.action} in {origin.seconds:.2f} s"
        if origin
        else f"index of {result.index_rows} rows"
    )
    print(
        f"lookup {result.dataset.root}: {target}; {index}; query "
        f"{result.query_seconds * 1e3:.2f} ms"
    )
    extra = [c for c in result.columns if c not in ("tip_x", "tip_y")]
    # the distances are in mm when the target is a tip alone, else in the index's scaled units
    tip_only = not extra and all(float(v) == 1.0 for v in result.scales)
    distance = "mm" if tip_only else "scaled"
    header = (
        f"{'#':>2}  {'N':>2}  {'state':<12}  {'status':<9}  {'tip x':>9}  {'tip y':>9}  "
        f"{'error':>9}  {'stiffness':>9}  "
        + "".join(f"{c:>12}  " for c in extra)
        + f"{'row dist':>9}  {'fit':<3}  design_id"
    )
    units = (
        f"{'':>2}  {'':>2}  {'':<12}  {'':<9}  {'mm':>9}  {'mm':>9}  {distance:>9}  {'N/mm':>9}  "
        + "".join(f"{'':>12}  " for _ in extra)
        + f"{distance:>9}"
    )
    # Where each printed value comes from: the verification solve, or the dataset row.
    provenance = result.provenance
    label = {"re-read-unverified": "unverified"}
    sources = (
        f"{'':>2}  {'':>2}  {'':<12}  {'':<9}  "
        f"{label.get(provenance['tip_x'], provenance['tip_x']):>9}  "
        f"{label.get(provenance['tip_y'], provenance['tip_y']):>9}  {'':>9}  "
        f"{label.get(provenance['stiffness'], provenance['stiffness']):>9}  "
        + "".join(f"{label.get(provenance[c], provenance[c]):>12}  " for c in extra)
        + f"{'re-read' if result.verified else 'unverified':>9}"
    )
    print(header)
    print(units)
    print(sources.rstrip())
    for rank, c in enumerate(result.candidates, start=1):
        values = dict(zip(result.columns, c.values, strict=True))
        print(
            f"{rank:>2}  {c.design.n_units:>2}  {c.state:<12}  {c.status:<9}  {c.tip[0]:9.4f}  "
            f"{c.tip[1]:9.4f}  {c.error:9.2e}  {c.stiffness:9.5f}  "
            + "".join(f"{values[e]:12.6g}  " for e in extra)
            + f"{c.source_distance:9.4f}  {'yes' if c.fitted_range else 'NO':<3}  {c.design_id}"
            + (" (refined)" if c.refined else "")
            + (f" (also {', '.join(str(i) for i in c.also_from)})" if c.also_from else "")
        )
    print(
        "key: error, row dist: distance from the target of the design and of the dataset row it\n"
        "     started from (design_id); re-solved: by the exact model at the design; re-read:\n"
        "     from the dataset row (checksum verified); fit: inside the closed forms' fitted range"
    )
    for note in result.notes:
        print(f"note: {note}")
    notes = {c.fitted_range_note for c in result.candidates if c.fitted_range_note}
    for note in sorted(notes):
        print(f"note: outside the fitted range of the closed forms: {note}")
    if written:
        print(f"{len(written)} designs written to {written[0].parent}")


def _plot(result, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..lookup.query import reachable_tips
    from ..plotting.lookup import plot_reachable

    # The region the lookup searched: the same numbers of units and state.
    tips = reachable_tips(result.index, result.n_units, result.state)
    target = None
    if {"tip_x", "tip_y"} <= set(result.columns):
        target = (
            result.target[result.columns.index("tip_x")],
            result.target[result.columns.index("tip_y")],
        )
    ax = plot_reachable(
        tips,
        target,
        [c.tip for c in result.candidates],
        labels=[c.status for c in result.candidates],
    )
    save_figure(ax.figure, path, dpi=150, bbox_inches="tight")
    plt.close(ax.figure)
    print(f"reachable tip region written to {path}", file=sys.stderr)
