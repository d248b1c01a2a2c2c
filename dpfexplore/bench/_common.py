"""Helpers shared by the benchmarks: machine facts, repeat-and-median timing, output."""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..model.formatting import json_text

#: Where ``--save`` writes benchmark records (kept in git as the latest figures).
REPORTS = Path("results") / "reports"


# ----------------------------------------------------------------------------- option types
# argparse ``type=`` callables: a bad value is refused by the parser in one line, before any
# benchmark work (``--units 0``, a misspelt material).


def count(low: int = 1) -> Callable[[str], int]:
    """An integer option of at least ``low`` (designs, rounds, budgets)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: need a whole number") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"{value}: need at least {low}")
        return value

    parse.__name__ = "count"  # argparse names the type in its messages
    return parse


def int_list(low: int, high: int) -> Callable[[str], list[int]]:
    """A comma-separated list of integers in ``[low, high]``, e.g. finger sizes ``2,5,8``."""

    def parse(text: str) -> list[int]:
        try:
            values = [int(v) for v in text.split(",") if v.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: need integers like 2,5,8") from None
        if not values or any(not low <= v <= high for v in values):
            raise argparse.ArgumentTypeError(f"{text!r}: need integers from {low} to {high}")
        return values

    parse.__name__ = "list"
    return parse


def name_list(names: Sequence[str]) -> Callable[[str], list[str]]:
    """A comma-separated list of names out of ``names``."""

    def parse(text: str) -> list[str]:
        values = [v.strip() for v in text.split(",") if v.strip()]
        unknown = [v for v in values if v not in names]
        if not values or unknown:
            raise argparse.ArgumentTypeError(
                f"{text!r}: choose among {', '.join(names)}"
                + (f" (not {unknown[0]!r})" if unknown else "")
            )
        return values

    parse.__name__ = "list"
    return parse


def dataset_options(parser: argparse.ArgumentParser, dataset: Path, job: Path) -> None:
    """Add ``--dataset`` (default ``dataset``) and ``--job`` (default ``job``, which makes it).

    For the benchmarks that time a command on a large sweep dataset, made once when missing.
    """
    parser.add_argument(
        "--dataset",
        type=Path,
        default=dataset,
        help=f"sweep dataset (default {dataset}; made if missing)",
    )
    parser.add_argument(
        "--job", type=Path, default=job, help="job that makes the dataset when it is missing"
    )


def machine_info() -> dict[str, Any]:
    """Facts about the machine and software a benchmark ran on."""
    import numba
    import numpy
    import scipy

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "numba_threads": numba.get_num_threads(),
        "threading_layer": _threading_layer(),
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
    }


def _threading_layer() -> str:
    import numba

    try:
        return numba.threading_layer()
    except ValueError:  # no parallel region has run yet
        return "not initialised"


def fresh_process_timings(probe: str) -> tuple[list[float], list[float]]:
    """Run ``probe`` (Python source printing numbers) twice against an empty Numba cache.

    The first run compiles every kernel it touches, the second loads them from the cache the
    first wrote; each returns the numbers the probe printed (e.g. seconds of its phases).
    """
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        runs = [
            subprocess.run(
                [sys.executable, "-c", textwrap.dedent(probe)],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout.split()
            for _ in range(2)
        ]
    return [float(v) for v in runs[0]], [float(v) for v in runs[1]]


def median_time(func: Callable[[], object], *, repeats: int = 7, min_time: float = 0.05) -> float:
    """Median wall time (s) of one call over ``repeats`` rounds, each of >= ``min_time`` s."""
    calls = 1
    while True:
        start = time.perf_counter()
        for _ in range(calls):
            func()
        elapsed = time.perf_counter() - start
        if elapsed >= min_time or calls >= 1 << 20:
            break
        calls *= 2
    samples = [elapsed / calls]
    for _ in range(repeats - 1):
        start = time.perf_counter()
        for _ in range(calls):
            func()
        samples.append((time.perf_counter() - start) / calls)
    return statistics.median(samples)


#: The compile-time fields of a run with ``--no-compile`` (null in JSON, not NaN).
NOT_MEASURED = {"compile_s": None, "cache_load_s": None}


def compile_line(record: dict[str, Any]) -> str:
    """The text line of a record's compile and cache-load times (or that they were skipped)."""
    if record.get("compile_s") is None:
        return "compile time not measured (--no-compile)"
    return (
        f"compile (cold cache) {record['compile_s']:.1f} s, cache load "
        f"{record['cache_load_s']:.2f} s"
    )


def emit(record: dict[str, Any], *, as_json: bool, text: str, save: Path | None = None) -> None:
    """Print a benchmark's result as JSON or text, and optionally save the JSON record."""
    if save is not None:
        save.parent.mkdir(parents=True, exist_ok=True)
        save.write_text(json_text(record) + "\n")
    if as_json:
        print(json_text(record))
    else:
        print(text)
