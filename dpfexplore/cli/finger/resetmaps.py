"""``dpfexplore reset-maps``: reset time against H, t and hold time, as Parquet + PNG."""

from __future__ import annotations

import time
from pathlib import Path

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.output import announce_compilation


def register(subparsers) -> None:
    """Add the ``reset-maps`` subcommand."""
    from ...solvers.dynamics.methods import DEFAULT_METHOD, METHODS

    parser = subparsers.add_parser(
        "reset-maps",
        help="reset-time maps against dome height, thickness and hold time (Parquet + PNG)",
        description="Simulate unit cells (or fingers of equal units) under a 0.7 MPa pulse and "
        "map each unit's reset time after release (s) against dome height H at t = 0.8 mm, "
        "dome thickness t at H = 3.0 mm, and the hold time tau3 - tau2. Writes "
        "reset_map_{H,t,hold}.parquet and reset_maps.png.",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results") / "reset-maps",
        help="result directory (written whole: reset_map_*.parquet, reset_maps.png)",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace --out when it holds an earlier result"
    )
    parser.add_argument("--units", type=int, default=1, help="units per finger (1: unit cell)")
    parser.add_argument(
        "--t-after",
        type=float,
        default=30.0,
        help="horizon after the release, s (longer resets are 'inf')",
    )
    parser.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        choices=sorted(n for n, i in METHODS.items() if i.integrator >= 0),
        help="integrator of the reset simulations",
    )
    parser.add_argument("--quick", action="store_true", help="coarse grids (a smoke run)")
    parser.set_defaults(handler=run)


def run(args) -> int:
    """Run the command; returns the exit code."""
    import numpy as np

    from ...io.result_dirs import ResultError, check_output_dir
    from ...solvers.dynamics.resetmaps import ResetMapSpec, reset_time_maps

    if not 1 <= args.units <= 12:
        raise UsageError(f"--units {args.units}: must be between 1 and 12")
    try:  # before minutes of simulation
        check_output_dir(args.out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    changes = {"n_units": args.units, "t_after": args.t_after, "method": args.method}
    if args.quick:
        changes.update(
            H_values=(2.6, 2.9, 3.2),
            t_values=(0.75, 0.85, 1.0),
            hold_values=(0.05, 1.0),
            hold_H=(2.9,),
        )
    announce_compilation("reset-maps", ["release" if args.method == "release" else "reset"])
    try:
        spec = ResetMapSpec(**changes)
        start = time.perf_counter()
        maps = reset_time_maps(spec)
        elapsed = time.perf_counter() - start
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    try:
        paths = write_reset_maps(maps, args.out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    failed = 0
    early = False
    for name, frame in maps.items():
        failed += int((frame["status"] != "ok").sum())
        finite = frame["reset_time"][np.isfinite(frame["reset_time"])]
        if len(finite):
            span = f"reset times {finite.min():.4g} to {finite.max():.4g} s"
            early |= bool(finite.min() < 0.0)
        else:
            span = "no finite reset time"
        print(
            f"{name:>5}: {frame['value'].nunique()} values, {len(frame)} unit rows, {span}, "
            f"{int(np.isinf(frame['reset_time']).sum())} never reset within "
            f"{spec.t_after:g} s"
        )
    if early:
        print(
            "note: reset times count from the end of the release ramp (tau4); a negative one "
            "is a unit that snapped back during the ramp, before the pressure reached zero"
        )
    print(f"computed in {elapsed:.1f} s (including any compilation); wrote:")
    for path in paths:
        print(f"  {path}")
    return EXIT_OK if failed == 0 else EXIT_FAILURE


def write_reset_maps(maps, directory: str | Path, *, force: bool = False) -> list[Path]:
    """Write each map as ``reset_map_<name>.parquet`` and all three as ``reset_maps.png``.

    The directory is a result directory (:mod:`dpfexplore.io.result_dirs`): written whole
    or not at all; one holding an earlier result is replaced only with ``force``.
    """
    from ...io.result_dirs import result_directory
    from ...plotting.dynamics import plot_reset_maps

    directory = Path(directory)
    names = [f"reset_map_{name}.parquet" for name in maps] + ["reset_maps.png"]
    with result_directory(directory, kind="reset-maps", force=force) as staging:
        for name, frame in maps.items():
            frame.to_parquet(staging / f"reset_map_{name}.parquet", index=False)
        plot_reset_maps(maps).savefig(staging / "reset_maps.png", dpi=120)
    paths = [directory / name for name in names]
    return paths
