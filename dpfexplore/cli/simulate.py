"""``dpfexplore simulate DESIGN.toml --P0 0.7 --tau 0,1,5,5.1 --t-end 15``: one dynamic scene."""

from __future__ import annotations

import json
from pathlib import Path

from . import EXIT_FAILURE, EXIT_OK, UsageError, error_line
from ._output import fitted_range_line, output_path


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    from ..solvers.dynamics import DEFAULT_METHOD, METHODS

    parser = subparsers.add_parser(
        "simulate",
        help="simulate a finger under a pressure profile: snap-through, snap-back, reset times",
        description="Simulate a finger from rest under a pressure pulse (MODEL.md §8) and report "
        "each unit's snap-through and snap-back times (s), its reset time after the end of the "
        "profile (s; 'inf' = still inverted at --t-end), its class and the final state.",
    )
    parser.add_argument("design", help="design TOML file (a [design] table) or an example name")
    parser.add_argument("--P0", type=float, default=0.7,
                        help="pulse pressure, MPa (default 0.7; 0 < P0 <= 2)")
    parser.add_argument(
        "--tau", default="0,1,5,5.1",
        help="tau1,tau2,tau3,tau4 in s: ramp start, full pressure, release start, release end",
    )  # fmt: skip
    parser.add_argument(
        "--profile", default=None,
        help="piecewise-linear profile 't:P,t:P,...' (s:MPa, 0 <= P <= 2), overrides --P0/--tau",
    )  # fmt: skip
    parser.add_argument("--t-end", type=float, default=15.0, help="end of the run, s")
    parser.add_argument(
        "--method", default=DEFAULT_METHOD,
        choices=sorted(name for name, info in METHODS.items() if info.model != "release"),
        help=f"integrator (default {DEFAULT_METHOD})",
    )  # fmt: skip
    parser.add_argument("--atol", type=float, default=None, help="position tolerance, mm")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--plot", type=Path, default=None, help="write a PNG of the run")
    parser.set_defaults(handler=run)


def _design(text: str):
    from ..examples import NAMES, example_path
    from ..model.design import load_design

    path = Path(text)
    if not path.exists() and text in NAMES:
        path = example_path(text)
    if not path.exists():
        raise UsageError(f"{text}: no such design file (examples: {', '.join(NAMES)})")
    return load_design(path)


def _profile(args):
    from ..solvers.dynamics import PressureProfile

    if args.profile:
        try:
            return PressureProfile.parse(args.profile)
        except ValueError as exc:
            raise UsageError(f"--profile: {exc}") from None
    try:
        tau = [float(v) for v in args.tau.split(",")]
    except ValueError:
        raise UsageError(f"--tau {args.tau}: give four comma-separated times in s") from None
    if len(tau) != 4:
        raise UsageError(f"--tau {args.tau}: give four comma-separated times in s")
    try:
        return PressureProfile.pulse(args.P0, tau)
    except ValueError as exc:
        option = "--P0" if str(exc).startswith("P0") else "--tau"
        raise UsageError(f"{option}: {exc}") from None


def run(args) -> int:
    """Run the command; returns the exit code."""
    from ..model.status import Status
    from ..solvers.dynamics import simulate

    try:
        design = _design(args.design)
        profile = _profile(args)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    plot = output_path(args.plot) if args.plot is not None else None
    if args.method != "radau":
        from ..solvers.compilation import compile_notice

        notice = compile_notice(["dynamics"])
        if notice:
            error_line(f"dpfexplore simulate: {notice} ...")
    try:
        result = simulate(design, profile, t_end=args.t_end, method=args.method, atol=args.atol)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    summary = result.to_dict()
    note = design.fitted_range_note
    summary["fitted_range"] = note is None
    summary["fitted_range_note"] = note
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"design {design.name or args.design}: {design.n_units} units, method "
              f"{result.method}, status {result.status.label}")  # fmt: skip
        print(f"final state {result.final_state} (unit 1 first); horizon {result.horizon:g} s "
              f"after the profile ends at {profile.t_release:g} s")  # fmt: skip
        print(f"{'unit':>4} {'class':>11} {'snap-through/s':>15} {'snap-back/s':>12} "
              f"{'reset/s':>10}")  # fmt: skip
        for k in range(design.n_units):
            print(f"{k + 1:>4} {result.unit_class[k] or 'never inv.':>11} "
                  f"{result.snap_through[k]:>15.4f} {result.snap_back[k]:>12.4f} "
                  f"{result.reset_time[k]:>10.4f}")  # fmt: skip
        if note is not None:
            print(fitted_range_line(note))
    if plot is not None:
        _save_plot(result, plot)
    return EXIT_OK if result.status == Status.OK else EXIT_FAILURE


def _save_plot(result, path: Path) -> None:
    from matplotlib.figure import Figure

    from ..plotting.dynamics import plot_simulation

    fig = Figure(figsize=(7, 7), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    plot_simulation(result, axes)
    fig.savefig(path, dpi=120)
