"""``dpfexplore sweep``, ``dpfexplore query`` and ``dpfexplore plot-space``.

* ``sweep JOB.toml [--out DIR] [--resume] [--engine local|dask] [--workers N]
  [--scheduler ADDR] [--chunk-size N]`` runs a job into a Parquet dataset (default
  ``results/<job name>``), with a progress bar on a terminal and log lines otherwise.
* ``query DIR --where "n_units == 5 and stiffness > 0.1" [--columns ...] [--csv FILE | --json]``
  selects committed rows with a :meth:`pandas.DataFrame.query` expression.
* ``plot-space DIR [--out FILE]`` draws the paper's design-space maps (Fig. S design space).

Exit codes: 0 done, 1 some chunks failed (``--resume`` retries them), 2 bad input (one line on
stderr; nothing written).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..sweep.driver import LogProgress
from . import EXIT_FAILURE, EXIT_OK, UsageError


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
    sweep.add_argument("--resume", action="store_true",
                       help="continue a directory of the same job: recompute what is missing")
    sweep.add_argument("--engine", choices=("local", "dask"), default="local",
                       help="local: this process on all cores (default); dask: Dask workers")
    sweep.add_argument("--workers", type=int, metavar="N",
                       help="dask: worker processes of the LocalCluster (default: one per "
                       "core); local: Numba threads")
    sweep.add_argument("--scheduler", metavar="ADDR",
                       help="dask: address of a running scheduler, e.g. tcp://host:8786 "
                       "(workers must share --out)")
    sweep.add_argument("--chunk-size", type=int, metavar="N",
                       help="designs per chunk file (default: the job's, else automatic)")
    sweep.set_defaults(handler=_sweep)

    query = subparsers.add_parser(
        "query",
        help="select rows of a sweep dataset",
        description="Select committed rows of a sweep dataset with a pandas query expression "
        "over its columns (units in the dataset schema; see README).",
    )
    query.add_argument("dir", type=Path, help="sweep dataset directory")
    query.add_argument("--where", help='filter, e.g. "n_units == 5 and stiffness > 0.1"')
    query.add_argument("--columns", nargs="+", metavar="COL",
                       help="columns to output (space- or comma-separated; default all)")
    output = query.add_mutually_exclusive_group()
    output.add_argument("--csv", type=Path, metavar="FILE", help="write CSV to FILE ('-': stdout)")
    output.add_argument("--json", action="store_true", help="print JSON records")
    query.set_defaults(handler=_query)

    plot = subparsers.add_parser(
        "plot-space",
        help="plot the design-space maps of a sweep dataset (tip, curvature, stiffness)",
        description="The paper's design-space figure: tip positions, curvature and stiffness "
        "of the all-inverted state of every converged design, by number of units.",
    )
    plot.add_argument("dir", type=Path, help="sweep dataset directory")
    plot.add_argument("--out", type=Path,
                      help="image file (default DIR.png beside the directory: files inside a "
                      "dataset directory would break pandas.read_parquet(DIR))")
    plot.set_defaults(handler=_plot_space)


# ----------------------------------------------------------------------------- sweep


class _BarProgress:
    """tqdm bar on the terminal: designs done, rate, ETA."""

    def __init__(self) -> None:
        self.bar = None

    def note(self, text: str) -> None:
        print(f"sweep: {text} ...", file=sys.stderr, flush=True)

    def start(self, total_designs: int, done_designs: int) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total_designs, initial=done_designs, unit="design",
                        unit_scale=True, dynamic_ncols=True, file=sys.stderr)

    def advance(self, record) -> None:
        self.bar.update(record.stop - record.start)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class _LineProgress(LogProgress):
    """One line on stderr per ``interval`` seconds (and at the end): for logs and pipes."""

    def note(self, text: str) -> None:
        self.emit(text)

    def emit(self, text: str) -> None:
        print(f"{time.strftime('%H:%M:%S')} sweep: {text}", file=sys.stderr, flush=True)


def _sweep(args: argparse.Namespace) -> int:
    from ..sweep.driver import run_sweep
    from ..sweep.engines import make_engine
    from ..sweep.space import JobSpecError, load_job
    from ..sweep.store import StoreError

    try:
        spec = load_job(args.job)
    except JobSpecError as exc:
        raise UsageError(str(exc)) from None
    if args.chunk_size is not None and args.chunk_size < 1:
        raise UsageError(f"--chunk-size {args.chunk_size}: must be >= 1")
    try:
        engine = make_engine(args.engine, workers=args.workers, scheduler=args.scheduler)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    out = args.out if args.out is not None else Path("results") / spec.name
    progress = _BarProgress() if sys.stderr.isatty() else _LineProgress()
    try:
        summary = run_sweep(
            spec, out, resume=args.resume, engine=engine, chunk_size=args.chunk_size,
            progress=progress,
        )
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    statuses = ", ".join(f"{name} {count}" for name, count in summary.statuses.items())
    timings = ", ".join(f"{name} {value:.2f} s" for name, value in summary.timings.items())
    print(
        f"sweep {spec.name}: {summary.n_designs} designs ({summary.designs_computed} computed "
        f"now, {summary.chunks_reused} of {summary.chunks_total} chunks reused), "
        f"{summary.rows} rows in {out}\n"
        f"  statuses: {statuses or 'none'}\n"
        f"  engine {summary.engine}: {timings}; total {summary.wall_s:.2f} s"
    )
    if summary.failures:
        for failure in summary.failures:
            print(f"  failed: {failure.task.path}: {failure.error}", file=sys.stderr)
        print(f"  {len(summary.failures)} chunks failed; rerun with --resume", file=sys.stderr)
        return EXIT_FAILURE
    return EXIT_OK


# ----------------------------------------------------------------------------- query


def _query(args: argparse.Namespace) -> int:
    from ..sweep.store import StoreError, read_results

    columns = None
    if args.columns:
        columns = [c for item in args.columns for c in item.split(",") if c]
    try:
        frame = read_results(args.dir, columns=columns, where=args.where)
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
            frame.to_csv(args.csv, index=False)
            print(f"{len(frame)} rows written to {args.csv}", file=sys.stderr)
    else:
        print(frame.to_string(max_rows=40, index=False))
        print(f"({len(frame)} rows)")
    return EXIT_OK


# ----------------------------------------------------------------------------- plot-space


def _plot_space(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plotting.space import SPACE_COLUMNS, plot_design_space
    from ..sweep.store import StoreError, read_results, read_schema

    try:
        names = read_schema(args.dir).names
        columns = [c for c in SPACE_COLUMNS if c in names]
        frame = read_results(args.dir, columns=columns)
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    try:
        axes = plot_design_space(frame)
    except ValueError as exc:
        raise UsageError(f"{args.dir}: {exc}") from None
    out = args.out if args.out is not None else args.dir.with_name(args.dir.name + ".png")
    figure = axes[0].figure
    figure.savefig(out, dpi=150)
    plt.close(figure)
    print(f"design-space maps written to {out}")
    return EXIT_OK
