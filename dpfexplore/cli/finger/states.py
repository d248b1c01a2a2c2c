"""``dpfexplore states DESIGN.toml``: the stable states of one finger."""

from __future__ import annotations

import argparse
import math
import sys

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.inputs import add_constants_option, design_of, model_record, print_constants_line
from ..support.output import (
    FIGURE_SUFFIXES,
    announce_compilation,
    error_line,
    fitted_range_line,
    json_text,
    output_path,
    save_figure,
)

UNITS_HELP = (
    "Units: lengths and tip coordinates in mm (model frame: base at the origin, limiting layer "
    "on y = h, finger along +x), energy in N·mm, smallest Hessian eigenvalue and tip stiffness "
    "in N/mm, apertures in mm. States are inversion vectors, unit 1 (the base) first."
)


def register(subparsers) -> None:
    """Add the ``states`` subcommand."""
    parser = subparsers.add_parser(
        "states",
        help="find every stable state of a design (or the N+1 sequential ones)",
        description="Search every state (2^N, or N+1 with --sequential) of the design in a TOML "
        "file ([design] table) and print a table. " + UNITS_HELP,
    )
    parser.add_argument(
        "design",
        help="TOML file with a [design] table, or a packaged example's name: gripper (the "
        "paper's gripper finger) or pickplace (its pick-and-place finger), in "
        "dpfexplore/examples/",
    )
    parser.add_argument("--sequential", action="store_true", help="only the N+1 sequential states")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--plot", metavar="FILE.png", help="draw the stable states to a PNG")
    add_constants_option(parser)
    parser.add_argument(
        "--gripper",
        nargs=2,
        type=float,
        metavar=("BASE_L", "THETA_DEG"),
        help="also give the gripper aperture (mm) for a base length (mm) and base angle (deg)",
    )
    parser.set_defaults(handler=run)


def _number(value: float):
    """JSON-safe float: NaN -> None, inf -> "inf"."""
    if math.isnan(value):
        return None
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore states``."""
    from ...model.gripper import gripper_aperture
    from ...solvers.lattice import spring_constants
    from ...solvers.statics import enumerate_states

    try:
        design = design_of(args)
    except (OSError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    announce_compilation("states", ["states"])
    results = enumerate_states(design, "sequential" if args.sequential else "all")
    h = spring_constants(design).h
    rows = []
    for r in results:
        row = {
            "state": r.requested,
            "found": r.found,
            "stable": r.stable,
            "status": r.status.label,
            "energy": _number(r.energy),
            "tip": [_number(r.tip[0]), _number(r.tip[1])],
            "min_eig": _number(r.min_eig),
            "stiffness": _number(r.stiffness),
        }
        if args.gripper:
            row["aperture"] = _number(float(gripper_aperture(r.tip, h, *args.gripper)))
        rows.append(row)
    note = design.fitted_range_note
    if args.json:
        document = {"design": design.to_dict(), **model_record(design), "states": rows}
        sys.stdout.write(json_text(document))
        print()
    else:
        _print_table(rows, design.n_units, bool(args.gripper))
        print_constants_line(design.constants)
        if note is not None:
            print(fitted_range_line(note))
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ...plotting.statics import plot_states, plot_states_grid

        if sum(r.stable for r in results) > 6:  # too many to overlay: one panel each
            save_figure(plot_states_grid(results), plot, dpi=150, bbox_inches="tight")
        else:
            ax = plot_states(results)
            save_figure(ax.figure, plot, dpi=150, bbox_inches="tight")
            plt.close(ax.figure)
    failed = [r for r in results if r.status.label not in ("ok", "collapsed")]
    if failed:
        error_line(f"dpfexplore states: {_failures_line(failed, len(results))}")
    return EXIT_FAILURE if failed else EXIT_OK


def _failures_line(failed: list, total: int) -> str:
    """One line: how many states were not solved, and each one's status (grouped)."""
    by_status: dict[str, list[str]] = {}
    for r in failed:
        by_status.setdefault(r.status.label, []).append(r.requested)
    shown = "; ".join(
        f"{', '.join(states[:8])}{', ...' if len(states) > 8 else ''}: {label}"
        for label, states in by_status.items()
    )
    return f"{len(failed)} of {total} states not solved ({shown}); their outputs are nan"


def _print_table(rows: list[dict], n_units: int, gripper: bool) -> None:
    width = max(n_units, 5)
    header = (
        f"{'state':<{width}}  {'found':<{width}}  {'stable':<6}  {'energy':>10}  "
        f"{'tip x':>8}  {'tip y':>8}  {'min eig':>9}  {'stiffness':>9}"
    )
    if gripper:
        header += f"  {'aperture':>8}"
    print(
        header + "\n" + f"{'':<{width}}  {'':<{width}}  {'':<6}  {'N·mm':>10}  {'mm':>8}  "
        f"{'mm':>8}  {'N/mm':>9}  {'N/mm':>9}" + (f"  {'mm':>8}" if gripper else "")
    )

    def fmt(value, spec):
        if value is None:
            return "nan"
        return value if isinstance(value, str) else format(value, spec)

    for row in rows:
        line = (
            f"{row['state']:<{width}}  {row['found'] or '-':<{width}}  "
            f"{'yes' if row['stable'] else 'no':<6}  {fmt(row['energy'], '10.4f'):>10}  "
            f"{fmt(row['tip'][0], '8.3f'):>8}  {fmt(row['tip'][1], '8.3f'):>8}  "
            f"{fmt(row['min_eig'], '9.5f'):>9}  {fmt(row['stiffness'], '9.5f'):>9}"
        )
        if gripper:
            line += f"  {fmt(row['aperture'], '8.2f'):>8}"
        print(line)
