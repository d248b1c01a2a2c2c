"""``dpfexplore simulate-leg LEG.toml [--json] [--plot out.png]``: a leg's tip path (§10)."""

from __future__ import annotations

from pathlib import Path

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.inputs import add_constants_option, constants_argument, with_constants
from ..support.output import FIGURE_SUFFIXES, json_text, output_path, save_figure


def register(subparsers) -> None:
    """Add the ``simulate-leg`` subcommand."""
    parser = subparsers.add_parser(
        "simulate-leg",
        help="simulate a leg (a chain of sections) and compose its tip's 3D path",
        description="Simulate each section of a leg alone under its own phase's pressure "
        "(MODEL.md §8, integrated only from the phase's start) and compose the sections into "
        "the tip's 3D path (MODEL.md §10). Reports each section's reset times (s, from the end "
        "of its phase) and unit classes, the tip path relative to its start (mm), and whether "
        "every section is inside the fitted range of the closed forms.",
    )
    parser.add_argument("leg", help="leg TOML file or an example name (walker-leg, walker-leg-2.5)")
    parser.add_argument(
        "--set",
        dest="assignments",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="change a section's design key, e.g. --set purple.H=2.5 or "
        "--set action.H=3.0,4.5,4.5,4.5 (repeatable)",
    )
    parser.add_argument("--method", default=None, help="integrator (default: the leg's, rodas4)")
    parser.add_argument("--atol", type=float, default=None, help="position tolerance, mm")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="FILE.png",
        help="write a PNG of the tip path (x-y and y-z projections)",
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


def _leg(text: str, assignments, constants=None):
    from ...examples import NAMES, example_path
    from ...solvers.legs.leg import apply_assignments, load_leg

    path = Path(text)
    if not path.exists() and text in NAMES:
        path = example_path(text)
    if not path.exists():
        raise UsageError(f"{text}: no such leg file (examples: walker-leg, walker-leg-2.5)")
    leg = apply_assignments(load_leg(path), assignments)
    if constants is None:
        return leg
    sets = {section.design.constants for section in leg.sections}
    for current in sets:
        with_constants(current, constants, str(path))
    return leg.with_constants(constants)


def run(args) -> int:
    """Run the command; returns the exit code."""
    from ...model.status import Status
    from ...solvers.legs.leg import simulate_leg

    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    try:
        leg = _leg(args.leg, args.assignments, constants_argument(args.constants))
        result = simulate_leg(leg, method=args.method, atol=args.atol)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    summary = result.to_dict()
    if args.json:
        print(json_text(summary, indent=None))
    else:
        _print_text(result, summary)
    if plot is not None:
        _save_plot(result, plot, args.assignments)
    return EXIT_OK if result.status == Status.OK else EXIT_FAILURE


def _print_text(result, summary) -> None:
    leg = result.leg
    print(
        f"leg {leg.name}: {len(leg.sections)} sections, composition {leg.composition}, "
        f"status {summary['status']}, horizon {leg.t_end:g} s"
    )
    for run in result.sections:
        s = run.section
        start = f"integrated from {run.t_start:g} s" if run.integrated else "at rest (no pressure)"
        print(f"section {s.name} (phase {s.phase}, H = {list(s.design.H)} mm): {start}")
        for k in range(s.design.n_units):
            print(
                f"  unit {k + 1}: {run.result.unit_class[k] or 'never inverted':>14}  "
                f"reset {run.result.reset_time[k]:8.4f} s"
            )
    dx, dy, dz = result.extent
    print(
        f"tip path: extent x {dx:.3f}, y {dy:.3f}, z {dz:.3f} mm; stride (diameter) "
        f"{result.stride:.3f} mm"
    )
    if not result.fitted_range:
        print(f"outside the fitted range: {result.fitted_range_note}")


def _save_plot(result, path: Path, assignments=()) -> None:
    from matplotlib.figure import Figure

    from ...plotting.leg import plot_tip_paths

    name = result.leg.name or "leg"
    # the legend names the leg that ran: the file's, changed by any --set
    label = f"{name} with {', '.join(assignments)}" if assignments else name
    fig = Figure(figsize=(11, 5), layout="constrained")
    plot_tip_paths(result, fig.subplots(1, 2), labels=[label])
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=120)
