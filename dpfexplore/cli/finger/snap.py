"""``dpfexplore snap DESIGN.toml``: the pressures at which a finger's units snap on a slow ramp."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.inputs import add_constants_option, constants_record, design_of, print_constants_line
from ..support.output import FIGURE_SUFFIXES, json_text, output_path, save_figure


def register(subparsers) -> None:
    """Add the ``snap`` subcommand."""
    parser = subparsers.add_parser(
        "snap",
        help="snap pressures: the states a slow pressure ramp visits and their windows",
        description="Follow the finger's equilibrium as the chamber pressure rises slowly from "
        "the flat finger (quasi-static continuation, MODEL.md §8 load), report every snap (fold "
        "of the branch; the landing decided by the equations of motion) and smooth threshold "
        "crossing with its pressure (MPa), and each visited state's pressure window and the "
        "state a slow release from it ends in. States are inversion vectors, unit 1 first.",
    )
    parser.add_argument("design", help="design TOML file (a [design] table) or an example name")
    parser.add_argument("--P-max", type=float, default=1.0, help="top of the ramp, MPa (1.0)")
    parser.add_argument("--P-min", type=float, default=0.0, help="bottom of the ramp, MPa (0)")
    parser.add_argument(
        "--direction",
        choices=("up", "down", "cycle"),
        default="up",
        help="rising ramp, falling ramp (snap-back pressures) or both",
    )
    parser.add_argument(
        "--start",
        default=None,
        metavar="STATE",
        help="start from this state (stable at P = 0) instead of flat",
    )
    parser.add_argument(
        "--P-start", type=float, default=None, help="pressure where the recorded ramp starts, MPa"
    )
    parser.add_argument(
        "--model",
        choices=("rodas4", "rodas4-overdamped"),
        default="rodas4",
        help="equations of motion deciding each landing",
    )
    parser.add_argument(
        "--no-release", action="store_true", help="skip the release of each visited state"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="FILE.png",
        help="draw each unit's extension and the tip against pressure",
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


def run(args) -> int:
    """Handler of ``dpfexplore snap``."""
    from ...model.status import Status
    from ...solvers.snap.continuation import snap_pressures

    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    try:
        design = design_of(args)
        seq = snap_pressures(
            design,
            P_max=args.P_max,
            P_min=args.P_min,
            direction=args.direction,
            start_state=args.start,
            P_start=args.P_start,
            release=not args.no_release,
            model=args.model,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    except RuntimeError as exc:
        print(f"dpfexplore snap: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    if args.json:
        print(json_text({**seq.to_dict(), "constants": constants_record(design.constants)}))
    else:
        print_constants_line(design.constants)
        _print_table(seq, design, args.design)
    if plot is not None:
        _save_plot(seq, plot)
    return EXIT_OK if seq.status == Status.OK else EXIT_FAILURE


def _fmt(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.6f}"


def _print_table(seq, design, name) -> None:
    print(
        f"design {design.name or name}: {design.n_units} units; ramp {seq.direction} "
        f"{seq.P_start:g} -> {seq.P_max if seq.direction != 'down' else seq.P_min:g} MPa; "
        f"landings: {seq.model}; status {seq.status.label}"
    )
    if not seq.fitted_range:
        print(f"warning: {design.fitted_range_note}: the closed forms are extrapolated")
    loose = [str(k + 1) for k, flag in enumerate(seq.no_contact) if flag]
    if loose:
        print(
            f"note: unit(s) {', '.join(loose)} have no dome contact (reach clamped to 0.01 mm): "
            "their events are the model's artefact"
        )
    print(
        f"{'pressure/MPa':>12}  {'event':<8}  {'before':>{design.n_units}} -> "
        f"{'after':<{design.n_units}}  units changed (+ inverted, - reverted)"
    )
    for e in seq.events:
        units = " ".join([f"+{k}" for k in e.inverted] + [f"-{k}" for k in e.reverted])
        if not units:
            # the fold's jump landed in the pattern the crossing just before had already made
            units = "none: the jump completes the crossing above"
        print(f"{e.pressure:>12.6f}  {e.kind:<8}  {e.before:>6} -> {e.after:<6}  {units}")
    print()
    print(
        f"{'state':<8} {'dir':<4} {'from/MPa':>10} {'to/MPa':>10} {'entered':<9} "
        f"{'released':<9} {'lost going down at/MPa':>22}"
    )
    for v in seq.visits:
        released = v.released or "-"
        print(
            f"{v.state:<8} {v.direction:<4} {v.P_enter:>10.6f} {_fmt(v.P_leave):>10} "
            f"{v.entered_by:<9} {released:<9} {_fmt(v.P_release_leave):>22}"
        )


def _save_plot(seq, path: Path) -> None:
    from matplotlib.figure import Figure

    from ...plotting.snap import plot_snap

    fig = Figure(figsize=(7, 7), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    plot_snap(seq, axes[0], quantity="u")
    plot_snap(seq, axes[1], quantity="tip")
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=120)
