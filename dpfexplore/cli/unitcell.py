"""``dpfexplore unitcell``: one dome unit's curve from its geometry and material.

* ``unitcell curve --H 3 --t 0.83 [--r-b 5 --E 26 --nu 0.35] [--travel MAX] [--json]
  [--plot FILE.png] [--out FILE.csv|.parquet]``: the equilibrium path of a pinned spherical cap
  under apex displacement control, through every fold (geometrically exact axisymmetric
  Kirchhoff shell; docs/guide/unitcell.md). ``--out`` writes the table ``identify fit`` reads.
* ``unitcell sweep JOB.toml --out DIR [--workers N]``: every geometry of a job (a grid or a
  Latin hypercube over ``H``, ``t``, ``r_b``, ``E``, ``nu``) traced on ``N`` processes into
  ``DIR/curves.parquet``, the table ``identify fit`` reads; resumable. Ctrl-C or SIGTERM stops
  it at once, keeping the committed chunks (exit code 130 or 143); the same command continues.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..io.progress import Progress
from . import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK, UsageError
from .support.output import (
    FIGURE_SUFFIXES,
    error_line,
    json_text,
    output_path,
    refuse_overwrite,
    save_figure,
    save_table,
)

#: Exit code of a sweep ended by SIGTERM (128 + 15, the shell's convention).
EXIT_TERMINATED = 128 + signal.SIGTERM

_TABLE_SUFFIXES = (".csv", ".parquet")


def register(subparsers) -> None:
    """Add ``unitcell`` and its subcommands."""
    parser = subparsers.add_parser(
        "unitcell",
        help="unit-cell mechanics: a dome unit's force and energy against apex travel",
        description=__doc__.split("\n\n", 1)[1],
    )
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    curve = sub.add_parser(
        "curve", help="trace one dome unit's path under apex displacement control"
    )
    curve.add_argument("--H", type=float, required=True, help="dome height, mm")
    curve.add_argument("--t", type=float, required=True, help="dome thickness, mm")
    curve.add_argument("--r-b", type=float, default=5.0, help="dome base radius, mm")
    curve.add_argument("--E", type=float, default=26.0, help="Young's modulus, MPa")
    curve.add_argument("--nu", type=float, default=0.35, help="Poisson ratio")
    curve.add_argument(
        "--travel", type=float, default=None, help="apex travel to trace to, mm (default 2.2 H)"
    )
    curve.add_argument(
        "--elements", type=int, default=None, help="segments along the meridian (default 128)"
    )
    curve.add_argument(
        "--step", type=float, default=None, help="largest continuation step, mm (travel/60)"
    )
    curve.add_argument("--max-steps", type=int, default=3000, help="most continuation steps")
    curve.add_argument("--json", action="store_true", help="print the run as one JSON document")
    curve.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="FILE.png",
        help="draw force and energy against travel (with the fitted spring law) and meridians",
    )
    curve.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="FILE.csv",
        help="write the path as the table identify fit reads (.csv or .parquet)",
    )
    curve.add_argument(
        "--force", action="store_true", help="replace the files --out and --plot name if they exist"
    )
    curve.set_defaults(handler=_curve)
    sweep = sub.add_parser(
        "sweep", help="trace every geometry of a job file into the table identify fit reads"
    )
    sweep.add_argument("job", type=Path, help="job file (TOML: [grid] or [lhs], [options])")
    sweep.add_argument("--out", type=Path, required=True, help="sweep directory (resumable)")
    sweep.add_argument("--workers", type=int, default=1, help="worker processes")
    sweep.add_argument(
        "--engine",
        choices=("local", "dask"),
        default="local",
        help="local: worker processes here (default); dask: a Dask cluster",
    )
    sweep.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="dask: address of a running scheduler, e.g. tcp://host:8786 (default: a "
        "LocalCluster of --workers processes)",
    )
    sweep.add_argument("--json", action="store_true", help="print the manifest as JSON")
    sweep.set_defaults(handler=_sweep)


def _sweep(args: argparse.Namespace) -> int:
    from ..io.commits import StoreError
    from ..unitcell.sweep import SweepIncomplete, SweepInterrupted, read_job, run_unitcell_sweep

    if args.workers < 1:
        raise UsageError(f"--workers {args.workers}: must be >= 1")
    try:
        job = read_job(args.job)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    terminated: list[int] = []
    try:
        with _sigterm_interrupts(terminated), Progress("unitcell sweep") as display:
            manifest = run_unitcell_sweep(
                job,
                args.out,
                workers=args.workers,
                progress=None if args.json else _chunks(display),
                engine=args.engine,
                scheduler=args.scheduler,
            )
    except (ValueError, StoreError) as exc:
        raise UsageError(str(exc)) from None
    except SweepIncomplete as exc:
        error_line(f"dpfexplore unitcell sweep: {exc}")
        return EXIT_FAILURE
    except SweepInterrupted as stop:
        how = "terminated (SIGTERM)" if terminated else "interrupted"
        error_line(
            f"dpfexplore unitcell sweep: {how}; {stop.chunks_committed} of {stop.chunks_total} "
            f"chunks ({stop.geometries_committed} of {stop.geometries} geometries) are committed "
            f"in {args.out}; continue with: dpfexplore unitcell sweep {args.job} --out {args.out}"
        )
        return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    except _Terminated:  # before the chunks started or while merging: nothing half-written
        error_line(f"dpfexplore unitcell sweep: terminated (SIGTERM); {args.out} is unchanged")
        return EXIT_TERMINATED
    except OSError as exc:  # a full disk while committing: what is committed stays valid
        error_line(
            f"dpfexplore unitcell sweep: writing {args.out} failed ({_reason(exc)}); the "
            "chunks committed so far are intact: run the same command again to continue"
        )
        return EXIT_FAILURE
    if args.json:
        print(json_text(manifest))
    else:
        counts = ", ".join(f"{n} {status}" for status, n in manifest["status"].items())
        print(f"{manifest['designs']} geometries: {counts}")
        print(
            f"wrote {args.out / manifest['curves']} (identify fit reads it) and "
            f"{args.out / manifest['summary']}"
        )
    failed = sum(n for s, n in manifest["status"].items() if s not in ("reached", "partial"))
    return EXIT_FAILURE if failed else EXIT_OK


def _reason(exc: OSError) -> str:
    """An OSError in words, with the file it names."""
    reason = exc.strerror or str(exc)
    return f"{exc.filename}: {reason}" if exc.filename else reason


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C would be: the sweep stops the same way."""


@contextmanager
def _sigterm_interrupts(received: list[int]) -> Iterator[None]:
    """SIGTERM stops the sweep as Ctrl-C does (workers ended, lock released, chunks kept).

    Without it SIGTERM ends this process at once, its lock left behind (taken over as stale by
    the next run). ``received`` gets the signal number. Only in the main thread.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        received.append(signum)
        raise _Terminated

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _chunks(display: Progress):
    """The sweep's ``progress(done, total)`` as the chunks' stage of ``display``."""

    def progress(done: int, total: int) -> None:
        if display.what is None:
            display.stage("chunks", total, done=done, unit="chunk")
        else:
            display.update(done)

    return progress


def _curve(args: argparse.Namespace) -> int:
    from ..unitcell import unit_cell_curve

    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    out = output_path(args.out, "--out", suffixes=_TABLE_SUFFIXES) if args.out else None
    for path, option in ((out, "--out"), (plot, "--plot")):
        if path is not None:
            refuse_overwrite(path, option, args.force)
    try:
        run = unit_cell_curve(
            args.H,
            args.t,
            args.r_b,
            args.E,
            args.nu,
            travel=args.travel,
            n_elements=args.elements,
            max_steps=args.max_steps,
            step=args.step,
        )
    except ValueError as exc:
        raise UsageError(_option_names(str(exc))) from None
    summary = _summary(run)
    if args.json:
        print(json_text(_document(run, summary)))
    else:
        _print_text(run, summary)
    if run.n_steps == 0:  # no point of the path: nothing to write or draw
        print(f"dpfexplore unitcell: {run.message}", file=sys.stderr)
        return EXIT_FAILURE
    try:
        if out is not None:
            rows = _write_table(run, out)
            if not args.json:
                print(f"wrote {out} ({rows} rows)")
        if plot is not None:
            _save_plot(run, plot)
    except OSError as exc:  # a full disk: the file is absent or as it was, never partial
        error_line(f"dpfexplore unitcell: cannot write {_reason(exc)}")
        return EXIT_FAILURE
    if run.status not in ("reached", "partial"):
        print(f"dpfexplore unitcell: {run.message}", file=sys.stderr)
        return EXIT_FAILURE
    return EXIT_OK


def _write_table(run, out: Path) -> int:
    """Write the run's table whole or not at all (``.csv`` or ``.parquet``); returns its rows."""
    frame = run.to_frame()
    save_table(frame, out)
    return len(frame)


def _option_names(message: str) -> str:
    """The API's parameter names as the command's options (``r_b=`` -> ``--r-b``)."""
    name, sep, rest = message.partition("=")
    options = {"n_elements": "elements", "r_b": "r-b", "max_steps": "max-steps"}
    if sep and name.isidentifier():
        return f"--{options.get(name, name)} {rest}"
    return message


def _summary(run) -> dict:
    from ..model.constants import dome_stiffness
    from ..unitcell.checks import shallow_shell_stiffness

    return {
        "status": run.status,
        "message": run.message,
        "steps": run.n_steps,
        "elements": run.n_elements,
        "seconds": round(run.elapsed, 4),
        "R": run.R,
        "initial_stiffness": run.initial_stiffness,
        "reissner_stiffness": shallow_shell_stiffness(run.E, run.nu, run.t, run.R),
        "paper_k_b": float(dome_stiffness(run.E, run.H, run.t, run.R)),
        "folds": [float(x) for x in run.folds],
        "tip_dis": run.tip_dis,
        "tip_kind": run.tip_kind,
        "bistable": run.bistable,
    }


def _document(run, summary: dict) -> dict:
    return {
        "inputs": {"H": run.H, "t": run.t, "r_b": run.r_b, "E": run.E, "nu": run.nu},
        "summary": summary,
        "zero_force_states": [
            {
                "displacement": s.displacement,
                "energy": s.energy,
                "stable": s.stable,
                "index": s.index,
                "branch": s.branch,
            }
            for s in run.zero_force_states
        ],
        "series": {
            "displacement": run.displacement.tolist(),
            "force": run.force.tolist(),
            "energy": run.energy.tolist(),
            "membrane_energy": run.membrane_energy.tolist(),
            "bending_energy": run.bending_energy.tolist(),
            "branch": run.branch.tolist(),
            "stable": run.stable.tolist(),
        },
    }


def _print_text(run, summary: dict) -> None:
    print(
        f"dome H {run.H:g} mm, t {run.t:g} mm, r_b {run.r_b:g} mm (R {run.R:.4g} mm), "
        f"E {run.E:g} MPa, nu {run.nu:g}: {run.n_elements} elements"
    )
    print(f"path: {summary['status']} ({run.message}); {run.n_steps} points in {run.elapsed:.3f} s")
    print(
        f"initial stiffness {run.initial_stiffness:.4g} N/mm (Reissner's shallow shell "
        f"{summary['reissner_stiffness']:.4g}, the paper's k_b {summary['paper_k_b']:.4g})"
    )
    if run.n_steps == 0:
        return
    folds = ", ".join(f"{x:.4g}" for x in run.folds) or "none"
    print(f"folds in apex travel (mm): {folds}")
    if run.tip_kind == "rest":
        print(f"stable inverted rest (tip_dis): {run.tip_dis:.5g} mm")
    elif run.tip_kind == "ghost":
        print(
            f"stable inverted rest: none (monostable); tip_dis from its ghost, the least force "
            f"{run.ghost.force:.4g} N past H: {run.tip_dis:.5g} mm"
        )
    else:
        print("stable inverted rest: none, and no least force past H (no tip_dis)")
    if run.zero_force_states:
        print("zero-force states: travel/mm  energy/N·mm  stable  negative eigenvalues")
        for s in run.zero_force_states:
            stable = "yes" if s.stable else "no"
            print(f"  {s.displacement:10.5g}  {s.energy:11.5g}  {stable:6}  {s.index}")
    step = max(1, math.ceil(run.n_steps / 30))
    rows = sorted({*range(0, run.n_steps, step), run.n_steps - 1})
    if len(rows) < run.n_steps:
        print(
            f"path table: {len(rows)} of its {run.n_steps} points (one in {step}, and the last; "
            "all of them with --out FILE.csv or --json):"
        )
    else:
        print(f"path table: all {run.n_steps} points:")
    print(f"{'travel/mm':>10} {'force/N':>10} {'energy/N·mm':>12} {'branch':>6} stable")
    for i in rows:
        print(
            f"{run.displacement[i]:10.5g} {run.force[i]:10.5g} {run.energy[i]:12.6g} "
            f"{run.branch[i]:6d} {'yes' if run.stable[i] else 'no'}"
        )


def _save_plot(run, path: Path) -> None:
    from matplotlib.figure import Figure

    from ..identification.curves import CurveError, curves_from_frame
    from ..identification.spring_fit import fit_curve
    from ..unitcell.plotting import plot_energy, plot_force, plot_meridians

    try:
        fit = fit_curve(curves_from_frame(run.to_frame())[0])
        spring = (fit.k_b, fit.alpha, fit.d)
    except CurveError:  # too few points or branches for the law: the curve alone
        spring = None
    fig = Figure(figsize=(8.5, 10), layout="constrained")
    axes = fig.subplots(3, 1)
    plot_force(run, axes[0], spring=spring)
    plot_energy(run, axes[1], spring=spring)
    plot_meridians(run, axes[2])
    save_figure(fig, path, dpi=110)
