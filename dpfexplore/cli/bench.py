"""``dpfexplore bench NAME [--json]``: benchmarks that run our code and a baseline side by side.

Each benchmark lives in :mod:`dpfexplore.bench` and registers its own options; see
:data:`BENCHMARKS`. ``--save`` writes the record ``results/reports/bench-NAME.json`` (tracked in
git: the documentation's benchmarks page is built from it) and never replaces one silently: a
record already there is refused before the benchmark runs, unless ``--force``, the rule of
``design --out`` and ``lookup --write``.
"""

from __future__ import annotations

import functools
import importlib
from pathlib import Path

from .support.output import refuse_overwrite

#: Benchmark name -> module under :mod:`dpfexplore.bench` providing ``register(subparsers)``.
BENCHMARKS = (
    "statics",
    "sweep",
    "dynamics",
    "sensitivities",
    "snap",
    "surrogate",
    "reset_model",
    "lookup",
    "design",
    "identify",
    "unitcell",
    "explore",
    "grasp",
)


def register(subparsers) -> None:
    """Add ``bench`` and its per-benchmark subcommands."""
    parser = subparsers.add_parser(
        "bench",
        help="run a benchmark (ours vs. the baseline, medians, ratios and errors)",
        description="Benchmarks print medians, ratios and errors against a trusted reference, "
        "plus the machine they ran on. Times in microseconds or seconds as labelled.",
    )
    bench_sub = parser.add_subparsers(dest="benchmark", metavar="BENCHMARK", required=True)
    for name in BENCHMARKS:
        importlib.import_module(f"dpfexplore.bench.{name}").register(bench_sub)
    for name, sub in bench_sub.choices.items():
        if any("--save" in action.option_strings for action in sub._actions):
            sub.add_argument(
                "--force",
                action="store_true",
                help="with --save: replace the record already saved under results/reports/",
            )
            sub.set_defaults(
                handler=functools.partial(_refuse_overwrite, name, sub.get_default("handler"))
            )
        sub.set_defaults(handler=_with_progress(name, sub.get_default("handler")))


def saved_record(name: str, args) -> Path:
    """The record ``bench NAME --save`` writes (``--save-as`` names it for ``bench design``)."""
    return Path("results") / "reports" / (getattr(args, "save_as", None) or f"bench-{name}.json")


def _refuse_overwrite(name: str, handler, args) -> int:
    """Run ``handler`` unless ``--save`` would replace a record without ``--force``.

    Raises
    ------
    UsageError
        Naming the record, before any benchmark work
        (:func:`~dpfexplore.cli.support.output.refuse_overwrite`).
    """
    if args.save:
        refuse_overwrite(saved_record(name, args), "--save", args.force)
    return handler(args)


def _with_progress(name: str, handler):
    """``handler`` run as a stage of a progress display: a line every few seconds it is silent."""

    def run(args):
        from ..io.progress import Progress

        with Progress("bench", boundaries=False) as display:
            display.stage(f"benchmark {name}")
            return handler(args)

    return run
