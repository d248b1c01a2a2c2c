"""``dpfexplore bench unitcell``: one dome's curve, speed against the mesh error.

For meshes of 32 to 256 elements along the meridian, on the corners and the centre of the
paper's box (``H`` 3-5 mm, ``t`` 0.5-1 mm, ``r_b`` 5 mm, ``E`` 26 MPa), one core: the median
time of one curve (the whole path to 2.2 H through every fold), its continuation steps, and its
error against a reference mesh of 512 elements: the largest difference of the lower energy
envelope (relative to its largest energy), of the first fold's travel and of ``tip_dis``. The
goal: one curve of ~200 steps in at most 1 s at the converged mesh (128 elements). Compile time
in a fresh process with an empty Numba cache, and the cache load, are measured apart.
"""

from __future__ import annotations

import argparse

import numpy as np

from ._common import NOT_MEASURED, REPORTS, compile_line, emit, fresh_process_timings, machine_info

#: Seconds one curve may take at the default mesh (issue 21).
GOAL_S = 1.0
#: The box's corners and centre.
DOMES = ((3.0, 0.5), (3.0, 1.0), (5.0, 0.5), (5.0, 1.0), (4.0, 0.75))
REFERENCE_ELEMENTS = 512

_PROBE = """
import time
start = time.perf_counter()
from dpfexplore.unitcell import unit_cell_curve
from dpfexplore.unitcell import shell
shell._announce()
print(time.perf_counter() - start)
"""


def register(subparsers) -> None:
    """Add ``bench unitcell``."""
    parser = subparsers.add_parser(
        "unitcell",
        help="unit-cell shell curve: time per curve against the mesh error",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"also write the record to {REPORTS}/bench-unitcell.json",
    )
    parser.add_argument(
        "--no-compile", action="store_true", help="skip the fresh-process compile measurement"
    )
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats per curve")
    parser.set_defaults(handler=run)


def _errors(run, reference) -> dict[str, float]:
    grid = np.linspace(0.0, 2.1 * run.H, 400)
    a, b = run.energy_envelope(grid), reference.energy_envelope(grid)
    both = np.isfinite(a) & np.isfinite(b)
    return {
        "energy": float(np.max(np.abs(a - b)[both]) / np.max(b[both])),
        "fold": float(abs(run.folds[0] / reference.folds[0] - 1.0)),
        "tip_dis": float(abs(run.tip_dis / reference.tip_dis - 1.0))
        if run.tip_dis and reference.tip_dis
        else float("nan"),
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench unitcell``."""
    from ..unitcell import unit_cell_curve
    from ..unitcell.shell import _announce

    if args.no_compile:
        timings = dict(NOT_MEASURED)
    else:
        cold, warm = fresh_process_timings(_PROBE)
        timings = {"compile_s": cold[0], "cache_load_s": warm[0]}
    _announce()
    references = {dome: unit_cell_curve(*dome, n_elements=REFERENCE_ELEMENTS) for dome in DOMES}
    rows = []
    for n in (32, 64, 128, 256):
        times, steps, errors = [], [], []
        for dome in DOMES:
            runs = [unit_cell_curve(*dome, n_elements=n) for _ in range(max(1, args.repeats))]
            times.append(float(np.median([r.elapsed for r in runs])))
            steps.append(runs[0].n_steps)
            errors.append(_errors(runs[0], references[dome]))
        rows.append(
            {
                "elements": n,
                "median_s": float(np.median(times)),
                "max_s": float(np.max(times)),
                "median_steps": float(np.median(steps)),
                "max_energy_error": max(e["energy"] for e in errors),
                "max_fold_error": max(e["fold"] for e in errors),
                "max_tip_dis_error": float(np.nanmax([e["tip_dis"] for e in errors])),
            }
        )
    record = {
        "benchmark": "unitcell",
        "machine": machine_info(),
        "domes": [list(d) for d in DOMES],
        "reference_elements": REFERENCE_ELEMENTS,
        "goal_s": GOAL_S,
        "rows": rows,
        **timings,
    }
    m = record["machine"]
    lines = [
        f"unitcell: {len(DOMES)} domes of the paper's box, one core; reference "
        f"{REFERENCE_ELEMENTS} elements",
        f"machine: {m['cpu']}, {m['cores']} cores; {m['date']}",
        compile_line(record),
        f"{'elements':>8} {'median/s':>9} {'max/s':>8} {'steps':>6} {'energy err':>11} "
        f"{'fold err':>9} {'tip err':>9}",
    ]
    for r in rows:
        lines.append(
            f"{r['elements']:>8d} {r['median_s']:>9.3f} {r['max_s']:>8.3f} "
            f"{r['median_steps']:>6.0f} {r['max_energy_error']:>11.2e} "
            f"{r['max_fold_error']:>9.2e} {r['max_tip_dis_error']:>9.2e}"
        )
    lines.append(f"goal: one curve <= {GOAL_S:g} s at 128 elements")
    save = REPORTS / "bench-unitcell.json" if args.save else None
    emit(record, as_json=args.json, text="\n".join(lines), save=save)
    return 0
