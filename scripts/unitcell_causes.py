"""Each cause of the unit-cell route's miss over the paper's box: the record.

Runs every dome of a grid of the paper's box through the fit recipes and reach models of
:mod:`dpfexplore.identification.causes` and writes the record
``results/reports/unitcell-causes.json`` (the tables, every dome's values, the command)::

    .venv/bin/python scripts/unitcell_causes.py   # 7 × 6 grid: 5-20 minutes on one core
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Sequence
from importlib.metadata import version
from pathlib import Path

import numpy as np

from dpfexplore.identification.causes import compact_units, run_grid, summarise
from dpfexplore.io.files import atomic_write


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Run the grid, write the record (JSON), print its tables."""
    parser = argparse.ArgumentParser(
        prog="scripts/unitcell_causes.py", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--n-H", type=int, default=7, help="grid points in H over [3, 5] mm")
    parser.add_argument("--n-t", type=int, default=6, help="grid points in t over [0.5, 1] mm")
    parser.add_argument("--json", type=Path, default=Path("results/reports/unitcell-causes.json"))
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    start = time.perf_counter()
    frame = run_grid(args.n_H, args.n_t)
    summary = summarise(frame)
    record = {
        "what": "each cause of the unit-cell route's miss, over the paper's box, against the "
        "paper's closed forms (dpfexplore.identification.causes)",
        "command": f"python scripts/unitcell_causes.py --n-H {args.n_H} --n-t {args.n_t} "
        f"--json {args.json}",
        "elapsed_s": time.perf_counter() - start,
        "versions": {name: version(name) for name in ("dpfexplore", "numpy", "scipy")},
        "summary": summary,
        "units": compact_units(frame),
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.json, json.dumps(_jsonable(record), indent=1) + "\n")
    print(json.dumps(_jsonable(summary), indent=1))
    print(f"{len(frame)} rows in {record['elapsed_s']:.0f} s; wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
