"""``dpfexplore sweep``, ``dpfexplore query`` and ``dpfexplore plot-space``.

* ``sweep JOB.toml [--out DIR] [--resume] [--repair] [--engine local|dask] [--workers N]
  [--scheduler ADDR] [--chunk-size N]`` runs a job into a Parquet dataset (default
  ``results/<job name>``), with a progress bar on a terminal and log lines otherwise. Rerun on
  a complete directory of the same job, it prints the summary and computes nothing.
* ``query DIR --where "n_units == 5 and stiffness > 0.1" [--columns ...] [--csv FILE | --json]
  [--no-verify]`` selects committed rows with a filter (:mod:`dpfexplore.sweep.storage.row_filter`).
* ``plot-space DIR [--out FILE]`` draws the paper's design-space maps (Fig. S design space).

Exit codes: 0 done, 1 some chunks failed (``--resume`` retries them), 2 bad input or a
directory that cannot be used, e.g. held by another sweep (one line on stderr; nothing written),
130 interrupted (one line: what is committed, how to resume).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from ..io.progress import Progress
from ..sweep.progress import DisplayProgress
from . import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK, UsageError, error_line
from .support.inputs import add_constants_option, constants_argument, constants_line, with_constants
from .support.output import FIGURE_SUFFIXES, output_path, save_figure, save_table


def register(subparsers) -> None:
    """Add the ``sweep``, ``query`` and ``plot-space`` subcommands."""
    sweep = subparsers.add_parser(
        "sweep",
        help="evaluate a job's design space into a resumable Parquet dataset",
        description="Sample a job's design space (jobs/*.toml) and evaluate it in chunks into a "
        "Parquet dataset, one row per design-state. Interrupted sweeps continue with --resume.",
    )
    sweep.add_argument("job", type=Path, help="job file (TOML), e.g. jobs/paper-design-space.toml")
    sweep.add_argument("--out", type=Path, help="dataset directory (default results/<job name>)")
    sweep.add_argument(
        "--resume",
        action="store_true",
        help="continue a directory of the same job: recompute what is missing",
    )
    sweep.add_argument(
        "--repair",
        action="store_true",
        help="rebuild a lost _manifest.json from the chunk files that verify "
        "against the job (then --resume computes the rest; both at once work)",
    )
    sweep.add_argument(
        "--engine",
        choices=("local", "dask"),
        default="local",
        help="local: this process on all cores (default); dask: Dask workers",
    )
    sweep.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="dask: worker processes of the LocalCluster (default: one per "
        "core); local: Numba threads",
    )
    sweep.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="dask: address of a running scheduler, e.g. tcp://host:8786 "
        "(workers must share --out)",
    )
    sweep.add_argument(
        "--chunk-size",
        type=int,
        metavar="N",
        help="designs per chunk file (default: the job's, else automatic)",
    )
    add_constants_option(sweep)
    sweep.set_defaults(handler=_sweep)

    query = subparsers.add_parser(
        "query",
        help="select rows of a sweep dataset",
        description="Select committed rows of a sweep dataset with a condition over its columns. "
        "The columns, their types, units and meanings: the documentation's 'Sweep dataset "
        "format' page (docs/formats/dataset.md); each column also carries its unit and "
        "description in the dataset's own schema.",
    )
    query.add_argument("dir", type=Path, help="sweep dataset directory")
    query.add_argument(
        "--where",
        help='rows for which this condition holds, e.g. "n_units == 5 and stiffness > 0.1" '
        "(columns, numbers, comparisons, and/or/not, + - * /, abs/sqrt/hypot/isnan)",
    )
    query.add_argument(
        "--columns",
        nargs="+",
        metavar="COL",
        help="columns to output (space- or comma-separated; 'all': every one); default: every "
        "column with --csv/--json, a summary table on the terminal (" + " ".join(_SUMMARY) + ")",
    )
    output = query.add_mutually_exclusive_group()
    output.add_argument("--csv", type=Path, metavar="FILE", help="write CSV to FILE ('-': stdout)")
    output.add_argument("--json", action="store_true", help="print JSON records")
    query.add_argument(
        "--no-verify",
        dest="verify",
        action="store_false",
        help="skip the SHA-256 check of each chunk against the manifest "
        "(faster; reads only the columns asked for)",
    )
    query.set_defaults(handler=_query)

    plot = subparsers.add_parser(
        "plot-space",
        help="plot the design-space maps of a sweep dataset (tip, curvature, stiffness)",
        description="The paper's design-space figure: tip positions, curvature and stiffness "
        "of the all-inverted state of every converged design, by number of units.",
    )
    plot.add_argument("dir", type=Path, help="sweep dataset directory")
    plot.add_argument(
        "--out",
        type=Path,
        help="image file (default DIR.png beside the directory: files inside a "
        "dataset directory would break pandas.read_parquet(DIR))",
    )
    plot.set_defaults(handler=_plot_space)


# ----------------------------------------------------------------------------- sweep


def _sweep(args: argparse.Namespace) -> int:
    from ..sweep.driver import SweepInterrupted, run_sweep
    from ..sweep.engines import make_engine
    from ..sweep.job_file import JobSpecError, load_job
    from ..sweep.storage.store import StoreError

    try:
        spec = load_job(args.job)
    except JobSpecError as exc:
        raise UsageError(str(exc)) from None
    given = constants_argument(args.constants)
    chosen = with_constants(spec.constants, given, str(args.job))
    if chosen is not spec.constants:
        spec = dataclasses.replace(
            spec, constants=chosen, constants_file=str(_located(args.constants).resolve())
        )
    if args.chunk_size is not None and args.chunk_size < 1:
        raise UsageError(f"--chunk-size {args.chunk_size}: must be >= 1")
    try:
        engine = make_engine(args.engine, workers=args.workers, scheduler=args.scheduler)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    out = args.out if args.out is not None else Path("results") / spec.name
    if args.repair:
        _repair(args, spec, out)
        if not args.resume:
            return EXIT_OK
    try:
        with Progress("sweep") as display:
            summary = run_sweep(
                spec,
                out,
                resume=args.resume,
                engine=engine,
                chunk_size=args.chunk_size,
                progress=DisplayProgress(display),
            )
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:  # a full disk while committing: what is committed stays valid
        error_line(
            f"dpfexplore sweep: writing {out} failed ({exc.strerror or exc}); the chunks "
            f"committed so far are intact; when fixed, continue with: dpfexplore sweep "
            f"{args.job} --out {out} --resume"
        )
        return EXIT_FAILURE
    except SweepInterrupted as stop:
        error_line(
            f"dpfexplore sweep: interrupted; {stop.chunks_committed} of {stop.chunks_total} "
            f"chunks ({stop.designs_committed} of {stop.n_designs} designs) are committed in "
            f"{out}; continue with: dpfexplore sweep {args.job} --out {out} --resume"
        )
        return EXIT_INTERRUPTED
    statuses = ", ".join(f"{name} {count}" for name, count in summary.statuses.items())
    timings = ", ".join(f"{name} {value:.2f} s" for name, value in summary.timings.items())
    print(
        f"sweep {spec.name}: {summary.n_designs} designs ({summary.designs_computed} computed "
        f"now, {summary.chunks_reused} of {summary.chunks_total} chunks reused), "
        f"{summary.rows} rows in {out}\n"
        f"  statuses: {statuses or 'none'}\n"
        f"  engine {summary.engine}: {timings}; total {summary.wall_s:.2f} s"
    )
    if constants_line(spec.constants):
        print(f"  {constants_line(spec.constants)}")
    note = spec.fitted_range_note()
    if note is not None:
        print(
            f"  note: the job's space leaves the range the closed forms were fitted on "
            f"({note}); the column fitted_range says which rows are extrapolated"
        )
    if summary.failures:
        for failure in summary.failures:
            error_line(f"  failed: {failure.task.path}: {failure.error}")
        error_line(f"  {len(summary.failures)} chunks failed; rerun with --resume")
        return EXIT_FAILURE
    return EXIT_OK


def _repair(args: argparse.Namespace, spec, out: Path) -> None:
    from ..sweep.repair import repair_sweep
    from ..sweep.storage.store import StoreError

    try:
        report = repair_sweep(spec, out, chunk_size=args.chunk_size)
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    remaining = report.chunks_total - len(report.committed)
    print(
        f"repair {spec.name}: rebuilt {out}/_manifest.json: {len(report.committed)} of "
        f"{report.chunks_total} chunks verified against the job and committed "
        f"({report.designs_committed} of {report.n_designs} designs)"
    )
    for path, why in report.rejected:
        print(f"  left out {path}: {why}")
    if remaining and not args.resume:
        print(f"  {remaining} chunks to compute: dpfexplore sweep {args.job} --out {out} --resume")


# ----------------------------------------------------------------------------- query

#: The columns ``query`` prints as a table when none are asked for: a row's design, state, status
#: and answer in about 90 characters (the whole row is 60-100 columns, 600 characters and more).
_SUMMARY = (
    "design_id",
    "n_units",
    "requested_bits",
    "found_bits",
    "status_label",
    "tip_x",
    "tip_y",
    "stiffness",
)


def _query(args: argparse.Namespace) -> int:
    from ..sweep.storage.store import StoreError, read_results

    columns = None
    if args.columns:
        columns = [c for item in args.columns for c in item.split(",") if c]
        if columns == ["all"]:
            columns = None
    try:
        frame = read_results(args.dir, columns=columns, where=args.where, verify=args.verify)
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    except KeyError as exc:
        raise UsageError(f"--columns: {exc.args[0]}") from None
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.json:
        print(frame.to_json(orient="records", double_precision=15))
    elif args.csv is not None:
        if str(args.csv) == "-":
            frame.to_csv(sys.stdout, index=False)
        else:
            csv = output_path(args.csv, "--csv")
            save_table(frame, csv)
            error_line(f"{len(frame)} rows written to {csv}")
    else:
        shown = frame
        if not args.columns:
            shown = frame[[c for c in _SUMMARY if c in frame.columns]]
        print(shown.to_string(max_rows=40, index=False))
        print(f"({len(frame)} rows)")
        if len(frame) > 40:
            print("(the first and last 20 shown; all of them with --csv or --json)")
        if shown.shape[1] < frame.shape[1]:
            print(
                f"({shown.shape[1]} of {frame.shape[1]} columns shown; --columns all for every "
                "one, --columns NAME ... to choose)"
            )
    return EXIT_OK


# ----------------------------------------------------------------------------- plot-space


def _plot_space(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plotting.space import SPACE_COLUMNS, plot_design_space
    from ..sweep.storage.store import StoreError, read_results, read_schema

    try:
        if not args.dir.is_dir():
            raise StoreError(f"{args.dir}: no such directory")
        names = read_schema(args.dir).names
        columns = [c for c in SPACE_COLUMNS if c in names]
        frame = read_results(args.dir, columns=columns)
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    try:
        axes = plot_design_space(frame)
    except ValueError as exc:
        raise UsageError(f"{args.dir}: {exc}") from None
    out = output_path(
        args.out if args.out is not None else args.dir.with_name(args.dir.name + ".png"),
        "--out",
        suffixes=FIGURE_SUFFIXES,
    )
    figure = axes[0].figure
    save_figure(figure, out, dpi=150)
    plt.close(figure)
    print(f"design-space maps written to {out}")
    return EXIT_OK


def _located(text: str) -> Path:
    """The file ``--constants`` names (a name resolved as every command resolves it)."""
    from ..model.constants_set import locate_constants_set

    return locate_constants_set(text)
