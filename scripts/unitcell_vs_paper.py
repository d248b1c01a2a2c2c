"""The shell model's spring constants beside the paper's closed forms: the record and figure.

Traces a grid of the paper's box with the shell model and sets its identified constants beside
the paper's (:mod:`dpfexplore.identification.compare_paper`), then writes the record
``results/reports/unitcell-vs-paper.json`` (every unit, the summary, the command) and the
stability maps ``results/reports/unitcell-vs-paper.png``::

    .venv/bin/python scripts/unitcell_vs_paper.py   # 7 × 6 grid, 128 elements; see --help

With ``--extended DIR`` it identifies a constants set from the ``dpfexplore unitcell sweep``
directory ``DIR`` instead (``identify``'s per-curve method unless ``--method``,
:func:`~dpfexplore.identification.compare_paper.identify_sweep`) and saves it under
``results/constants/NAME``: how the packaged ``shell-extended`` was made::

    .venv/bin/python scripts/unitcell_vs_paper.py --extended results/unitcell/shell-extended
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from importlib.metadata import version
from pathlib import Path

import numpy as np

from dpfexplore.identification.compare_paper import (
    PAPER_BOX,
    compare_grid,
    identify_sweep,
    plot_maps,
    summarise,
)
from dpfexplore.identification.identify import DEFAULT_METHOD
from dpfexplore.identification.report import (
    format_report,
    read_identification,
    save_identification,
)
from dpfexplore.io.files import atomic_write
from dpfexplore.model.constants_set import DEFAULT
from dpfexplore.unitcell import DEFAULT_ELEMENTS


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


def _extended(directory: Path, name: str, method: str) -> int:
    """Identify a constants set from a unitcell sweep, save it, print its report."""
    result = identify_sweep(directory, name=name, method=method)
    out = Path("results") / "constants" / name
    save_identification(result, out, plot=True, force=True)
    _, report = read_identification(out)
    print(format_report(report))
    print(f"saved to {out}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Trace the grid, write the record (JSON) and the figure; print the summary."""
    parser = argparse.ArgumentParser(
        prog="scripts/unitcell_vs_paper.py", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--n-H", type=int, default=7, help="grid points in H over [3, 5] mm")
    parser.add_argument("--n-t", type=int, default=6, help="grid points in t over [0.5, 1] mm")
    parser.add_argument("--elements", type=int, default=DEFAULT_ELEMENTS)
    parser.add_argument("--json", type=Path, default=Path("results/reports/unitcell-vs-paper.json"))
    parser.add_argument("--plot", type=Path, default=Path("results/reports/unitcell-vs-paper.png"))
    parser.add_argument(
        "--extended",
        type=Path,
        default=None,
        help="instead: identify a set from this unitcell sweep directory and save it under "
        "results/constants/NAME",
    )
    parser.add_argument("--name", default="shell-extended", help="name of the --extended set")
    parser.add_argument(
        "--method",
        choices=("states", "features", "least_squares"),
        default=DEFAULT_METHOD,
        help="per-curve fit of the --extended set (default: identify's)",
    )
    args = parser.parse_args(argv)
    if args.extended is not None:
        return _extended(args.extended, args.name, args.method)
    H_values = np.linspace(*PAPER_BOX["H"], args.n_H)
    t_values = np.linspace(*PAPER_BOX["t"], args.n_t)
    start = time.perf_counter()
    frame = compare_grid(H_values, t_values, n_elements=args.elements)
    elapsed = time.perf_counter() - start
    summary = summarise(frame)
    record = {
        "what": "shell model (dpfexplore.unitcell; states and features fits; the cap's and the "
        "cell's tip_dis) against the paper's closed forms (DEFAULT set) over the paper's box; "
        "neither tuned to the other",
        "command": "python scripts/unitcell_vs_paper.py "
        f"--n-H {args.n_H} --n-t {args.n_t} --elements {args.elements} "
        f"--json {args.json} --plot {args.plot}",
        "settings": {
            "H": [float(v) for v in H_values],
            "t": [float(v) for v in t_values],
            "r_b": PAPER_BOX["r_b"],
            "E": PAPER_BOX["E"],
            "nu": PAPER_BOX["nu"],
            "n_elements": args.elements,
            "constants": DEFAULT.name,
        },
        "elapsed_s": elapsed,
        "versions": {name: version(name) for name in ("dpfexplore", "numpy", "scipy")},
        "summary": summary,
        "units": frame.to_dict("records"),
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.json, json.dumps(_jsonable(record), indent=1) + "\n")
    fig = plot_maps(frame)
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.plot, dpi=130)
    print(json.dumps(_jsonable(summary), indent=1))
    print(f"{len(frame)} units in {elapsed:.1f} s; wrote {args.json} and {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
