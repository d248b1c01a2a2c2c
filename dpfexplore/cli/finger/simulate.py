"""``dpfexplore simulate DESIGN.toml --P0 0.7 --tau 0,1,5,5.1 --t-end 15``: one dynamic scene."""

from __future__ import annotations

import json
import math
from pathlib import Path

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.inputs import add_constants_option, design_of, model_record, print_constants_line
from ..support.output import (
    FIGURE_SUFFIXES,
    announce_compilation,
    fitted_range_line,
    json_text,
    output_path,
    save_figure,
)


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    from ...solvers.dynamics.methods import DEFAULT_METHOD, METHODS

    parser = subparsers.add_parser(
        "simulate",
        help="simulate a finger under a pressure profile: snap-through, snap-back, reset times",
        description="Simulate a finger from rest under a pressure pulse (MODEL.md §8) and report "
        "each unit's snap-through and snap-back times (s), its reset time after the end of the "
        "profile (s; 'inf' = still inverted at --t-end), its class and the final state.",
    )
    parser.add_argument("design", help="design TOML file (a [design] table) or an example name")
    parser.add_argument(
        "--P0", type=float, default=0.7, help="pulse pressure, MPa (default 0.7; 0 < P0 <= 2)"
    )
    parser.add_argument(
        "--tau",
        default="0,1,5,5.1",
        help="tau1,tau2,tau3,tau4 in s: ramp start, full pressure, release start, release end",
    )
    parser.add_argument(
        "--profile",
        default=None,
        help="piecewise-linear profile 't:P,t:P,...' (s:MPa, 0 <= P <= 2), overrides --P0/--tau",
    )
    parser.add_argument("--t-end", type=float, default=15.0, help="end of the run, s")
    parser.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        choices=sorted(name for name, info in METHODS.items() if info.model != "release"),
        help=f"integrator (default {DEFAULT_METHOD})",
    )
    parser.add_argument("--atol", type=float, default=None, help="position tolerance, mm")
    parser.add_argument(
        "--max-rel-halfwidth",
        type=float,
        default=None,
        help="--method fast: run the full model where a unit's 90%% interval is wider",
    )
    parser.add_argument(
        "--reset-model", default=None, help="--method fast: model file (default: the packaged one)"
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument(
        "--plot", type=Path, default=None, metavar="FILE.png", help="write a PNG of the run"
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


def _profile(args):
    from ...solvers.dynamics.simulate import PressureProfile

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
    from ...model.status import Status
    from ...solvers.dynamics.simulate import simulate

    if args.method != "fast" and (args.max_rel_halfwidth is not None or args.reset_model):
        raise UsageError("--max-rel-halfwidth and --reset-model need --method fast")
    try:
        design = design_of(args)
        profile = _profile(args)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.method == "fast":
        if args.plot is not None:
            raise UsageError("--plot: the fast model computes no trajectory; drop --plot")
        try:
            return _run_fast(args, design, profile)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    plot = (
        output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
        if args.plot is not None
        else None
    )
    if args.method != "radau":
        announce_compilation("simulate", ["dynamics"])
    try:
        result = simulate(design, profile, t_end=args.t_end, method=args.method, atol=args.atol)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    summary = {**result.to_dict(), **model_record(design)}
    note = design.fitted_range_note
    if args.json:
        print(json_text(summary))
    else:
        print_constants_line(design.constants)
        print(
            f"design {design.name or args.design}: {design.n_units} units, method "
            f"{result.method}, status {result.status.label}"
        )
        print(
            f"final state {result.final_state} (unit 1 first); horizon {result.horizon:g} s "
            f"after the profile ends at {profile.t_release:g} s"
        )
        print(
            f"{'unit':>4} {'class':>11} {'snap-through/s':>15} {'snap-back/s':>12} {'reset/s':>10}"
        )
        for k in range(design.n_units):
            print(
                f"{k + 1:>4} {result.unit_class[k] or 'never inv.':>11} "
                f"{result.snap_through[k]:>15.4f} {result.snap_back[k]:>12.4f} "
                f"{result.reset_time[k]:>10.4f}"
            )
        if note is not None:
            print(fitted_range_line(note))
    if plot is not None:
        _save_plot(result, plot)
    return EXIT_OK if result.status == Status.OK else EXIT_FAILURE


def _run_fast(args, design, profile) -> int:
    """``--method fast``: one row of ``reset_times_batch(method="fast")``, printed like a run."""
    from ...model.design import DesignBatch
    from ...model.status import Status
    from ...solvers.dynamics.fast_reset import FALLBACK_REASONS
    from ...solvers.dynamics.simulate import CLASS_NAMES, reset_times_batch

    out = reset_times_batch(
        DesignBatch.from_designs([design]),
        profile,
        t_end=args.t_end,
        method="fast",
        atol=args.atol,
        max_rel_halfwidth=args.max_rel_halfwidth,
        model=args.reset_model,
    )
    n = design.n_units
    status = Status(int(out["status"][0]))
    reset, lo, hi = (out[k][0, :n] for k in ("reset_time", "reset_time_lo", "reset_time_hi"))
    classes = [CLASS_NAMES[int(c)] for c in out["unit_class"][0, :n]]
    reasons = [
        text for bit, text in FALLBACK_REASONS.items() if int(out["fallback_reason"][0]) & bit
    ]
    state = int(out["final_state"][0])
    final = format(state, f"0{n}b") if state >= 0 else None

    def times(values):
        return [
            None if math.isnan(v) else ("inf" if math.isinf(v) else round(float(v), 9))
            for v in values
        ]

    if args.json:
        print(
            json.dumps(
                {
                    "final_state": final,
                    "reset_times": times(reset),
                    "reset_time_interval": [times(lo), times(hi)],
                    "snap_through": times(out["snap_through"][0, :n]),
                    "snap_back": times(out["snap_back"][0, :n]),
                    "classes": classes,
                    "status": status.label,
                    "method": "fast",
                    "fallback": bool(out["fallback"][0]),
                    "fallback_reasons": reasons,
                    "horizon": args.t_end - profile.t_release,
                    "t_release": profile.t_release,
                    **model_record(design),
                },
                indent=2,
            )
        )
    else:
        print(
            f"design {design.name or args.design}: {n} units, method fast"
            f"{' (fell back to rodas4: ' + '; '.join(reasons) + ')' if reasons else ''}, "
            f"status {status.label}"
        )
        print(
            f"final state {final} (unit 1 first); horizon {args.t_end - profile.t_release:g} s "
            f"after the profile ends at {profile.t_release:g} s"
        )
        print(f"{'unit':>4} {'class':>11} {'reset/s':>10} {'90% interval/s':>23}")
        for k in range(n):
            print(
                f"{k + 1:>4} {classes[k] or 'never inv.':>11} {reset[k]:>10.4f} "
                f"{lo[k]:>11.4f} {hi[k]:>11.4f}"
            )
        if design.fitted_range_note is not None:
            print(fitted_range_line(design.fitted_range_note))
    return EXIT_OK if status == Status.OK else EXIT_FAILURE


def _save_plot(result, path: Path) -> None:
    from matplotlib.figure import Figure

    from ...plotting.dynamics import plot_simulation

    fig = Figure(figsize=(7, 7), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    plot_simulation(result, axes)
    save_figure(fig, path, dpi=120)
