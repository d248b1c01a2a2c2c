"""Helpers shared by the benchmarks: machine facts, repeat-and-median timing, output."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: Where ``--save`` writes benchmark records (kept in git as the latest figures).
REPORTS = Path("results") / "reports"


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


def emit(record: dict[str, Any], *, as_json: bool, text: str, save: Path | None = None) -> None:
    """Print a benchmark's result as JSON or text, and optionally save the JSON record."""
    if save is not None:
        save.parent.mkdir(parents=True, exist_ok=True)
        save.write_text(json.dumps(record, indent=2, default=float) + "\n")
    if as_json:
        print(json.dumps(record, indent=2, default=float))
    else:
        print(text)
