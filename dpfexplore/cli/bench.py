"""``dpfexplore bench NAME [--json]``: benchmarks that run our code and a baseline side by side.

Each benchmark lives in :mod:`dpfexplore.bench` and registers its own options; see
:data:`BENCHMARKS`.
"""

from __future__ import annotations

import importlib

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
        sub.set_defaults(handler=_with_progress(name, sub.get_default("handler")))


def _with_progress(name: str, handler):
    """``handler`` run as a stage of a progress display: a line every few seconds it is silent."""

    def run(args):
        from ..io.progress import Progress

        with Progress("bench", boundaries=False) as display:
            display.stage(f"benchmark {name}")
            return handler(args)

    return run
