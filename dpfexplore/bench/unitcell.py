"""``dpfexplore bench unitcell``: one dome's curve, speed against the mesh error.

For meshes of 32 to 256 elements along the meridian, on the corners and the centre of the
paper's box (``H`` 3-5 mm, ``t`` 0.5-1 mm, ``r_b`` 5 mm, ``E`` 26 MPa), one core: the median
time of one curve (the whole path to 2.2 H through every fold), its continuation steps, and its
error against a reference mesh of 512 elements: the largest difference of the lower energy
envelope (relative to its largest energy), of the first fold's travel and of ``tip_dis``. The
goal: one curve of ~200 steps in at most 1 s at the converged mesh (128 elements). Compile time
in a fresh process with an empty Numba cache, and the cache load, are measured apart.

With ``--grid N``, the grid goal: about ``N`` geometries of the box (an ``H`` x ``t``
grid, ``r_b`` 5 mm, ``E`` 26 MPa) traced by the unit-cell sweep
(:func:`~dpfexplore.unitcell.sweep.run_unitcell_sweep`, ``--workers`` processes, Parquet
included) into a temporary directory: wall time from start to manifest, and the statuses. The
goal: 1,000 curves in at most 10 minutes on 2 cores.

Side by side, the independent discretisation (:mod:`dpfexplore.unitcell.solid_check`: a 2-D
axisymmetric solid with scikit-fem, neo-Hookean, rigid apex column of radius t/2) on two thick
domes: its time per curve and the largest energy difference from the shell over the stable
first branch (0.25 H to the first fold).

The two-unit run (:func:`~dpfexplore.unitcell.contact.two_unit_rest`: the dome inverted against
its neighbour's wall at a finger's gap, the wall on a spring, the cap in its unit cell's plate)
on the same domes: the median time of one run and, per dome, its ``tip_dis`` against the
reference mesh's (mm). The goal: one run in at most 2 s.
"""

from __future__ import annotations

import argparse

import numpy as np

from ._common import NOT_MEASURED, REPORTS, compile_line, emit, fresh_process_timings, machine_info

#: Seconds one curve may take at the default mesh (the goal, docs/decisions.md).
GOAL_S = 1.0
#: Seconds a 1,000-curve grid may take on 2 cores (the goal).
GRID_GOAL_S = 600.0
#: Seconds one two-unit run may take (the goal).
TWO_UNIT_GOAL_S = 2.0
#: The wall's distance from the dome's base plane in the two-unit runs, mm (U_sep 1 mm plus half
#: a 1 mm chamber wall), and the wall's spring, N/mm.
TWO_UNIT_GAP = 1.5
TWO_UNIT_WALL = 1.0
#: The box's corners and centre.
DOMES = ((3.0, 0.5), (3.0, 1.0), (5.0, 0.5), (5.0, 1.0), (4.0, 0.75))
#: The domes of the two-unit runs.
TWO_UNIT_DOMES = DOMES
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
    parser.add_argument(
        "--no-solid", action="store_true", help="skip the scikit-fem solid side by side"
    )
    parser.add_argument(
        "--grid",
        type=int,
        default=0,
        metavar="N",
        help="also trace a grid of about N geometries of the box by the unit-cell sweep (0: skip)",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="worker processes of the --grid sweep"
    )
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


SOLID_DOMES = ((3.0, 1.0), (4.0, 1.0))


def _solid_side_by_side() -> list[dict]:
    """The scikit-fem solid and the shell on thick domes: time and energy difference.

    The comparison of the cross-check's report (:func:`dpfexplore.unitcell.solid_report.compare`:
    raw relative energy difference over 0.25 H to the first fold of either model).
    """
    from ..unitcell.solid_check import solid_curve, solid_stiffness
    from ..unitcell.solid_report import compare, shell_first_branch

    rows = []
    for H, t in SOLID_DOMES:
        solid = solid_curve(H, t)
        shell = shell_first_branch(H, t, 5.0, 26.0, 0.35)
        found = compare(solid, shell, solid_stiffness(H, t))
        rows.append(
            {
                "H": H,
                "t": t,
                "solid_cpu_s": float(solid.cpu),
                "solid_dofs": int(solid.n_dofs),
                "shell_s": float(shell["cpu"]),
                "max_energy_difference": found["raw"]["max_abs"],
                "window_mm": found["window_mm"],
            }
        )
    return rows


def _two_unit_runs(repeats: int) -> dict:
    """Two-unit runs on the box's domes: median time per run, ``tip_dis`` error (mm) by mesh."""
    from ..unitcell.contact import two_unit_rest
    from ..unitcell.geometry import square_plate

    def run_one(dome, n_elements=None):
        return two_unit_rest(
            *dome,
            gap=TWO_UNIT_GAP,
            wall_stiffness=TWO_UNIT_WALL,
            plate=square_plate(),
            n_elements=n_elements,
        )

    run_one(TWO_UNIT_DOMES[0])  # compiled and loaded before timing
    times, errors, domes = [], [], []
    for dome in TWO_UNIT_DOMES:
        runs = [run_one(dome) for _ in range(max(1, repeats))]
        times.append(float(np.median([r.elapsed for r in runs])))
        reference = run_one(dome, REFERENCE_ELEMENTS)
        if runs[0].tip_dis is not None and reference.tip_dis is not None:
            errors.append(abs(runs[0].tip_dis - reference.tip_dis))
        domes.append(
            {"H": dome[0], "t": dome[1], "tip_dis": runs[0].tip_dis, "reference": reference.tip_dis}
        )
    return {
        "gap_mm": TWO_UNIT_GAP,
        "wall_N_per_mm": TWO_UNIT_WALL,
        "domes": domes,
        "median_s": float(np.median(times)),
        "max_s": float(np.max(times)),
        "max_tip_dis_error_mm": float(max(errors)) if errors else float("nan"),
        "domes_with_rest": len(errors),
        "goal_s": TWO_UNIT_GOAL_S,
    }


def _grid_sweep(n: int, workers: int) -> dict:
    """About ``n`` geometries of the box traced by the unit-cell sweep: wall time and statuses."""
    import tempfile
    import time

    from ..unitcell.sweep import job_from_dict, run_unitcell_sweep

    n_t = max(1, round(np.sqrt(n / 2.0)))
    n_h = max(1, round(n / n_t))
    grid = {
        "H": np.linspace(3.0, 5.0, n_h).tolist(),
        "t": np.linspace(0.5, 1.0, n_t).tolist(),
        "r_b": [5.0],
        "E": [26.0],
        "nu": [0.35],
    }
    job = job_from_dict({"grid": grid})
    with tempfile.TemporaryDirectory(prefix="dpfexplore-bench-unitcell-") as out:
        start = time.perf_counter()
        manifest = run_unitcell_sweep(job, out, workers=workers)
        wall = time.perf_counter() - start
    curves = len(job.geometries)
    return {
        "curves": curves,
        "grid": [n_h, n_t],
        "workers": workers,
        "elements": job.options["n_elements"],
        "wall_s": wall,
        "per_curve_s": wall / curves,
        "goal_s": GRID_GOAL_S * curves / 1000.0,
        "statuses": manifest["status"],
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench unitcell``."""
    if args.grid < 0 or args.workers < 1:
        raise SystemExit("bench unitcell: --grid must be >= 0 and --workers >= 1")
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
    solid = [] if args.no_solid else _solid_side_by_side()
    two_unit = _two_unit_runs(args.repeats)
    grid = _grid_sweep(args.grid, args.workers) if args.grid else None
    record = {
        "benchmark": "unitcell",
        "solid_side_by_side": solid,
        "two_unit": two_unit,
        "machine": machine_info(),
        "domes": [list(d) for d in DOMES],
        "reference_elements": REFERENCE_ELEMENTS,
        "goal_s": GOAL_S,
        "rows": rows,
        "grid_sweep": grid,
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
    for r in solid:
        lines.append(
            f"solid cross-check H={r['H']:g} t={r['t']:g}: scikit-fem {r['solid_cpu_s']:.2f} s CPU "
            f"({r['solid_dofs']} unknowns) vs shell {r['shell_s']:.3f} s "
            f"CPU ({r['solid_cpu_s'] / r['shell_s']:.0f}x); energy difference "
            f"{100 * r['max_energy_difference']:.2f} % over 0.25 H..first fold"
        )
    lines.append(
        f"two-unit run (plate, wall at {two_unit['gap_mm']:g} mm on "
        f"{two_unit['wall_N_per_mm']:g} N/mm): median "
        f"{two_unit['median_s']:.3f} s, max {two_unit['max_s']:.3f} s per run (goal "
        f"{two_unit['goal_s']:g} s); largest tip_dis difference "
        f"{two_unit['max_tip_dis_error_mm']:.2e} mm from {REFERENCE_ELEMENTS} elements "
        f"({two_unit['domes_with_rest']} of {len(TWO_UNIT_DOMES)} domes come to rest; the others "
        "have no inverted rest to start from)"
    )
    if grid is not None:
        lines.append(
            f"grid: {grid['curves']} curves ({grid['grid'][0]} H x {grid['grid'][1]} t, "
            f"{grid['elements']} elements) by the unit-cell sweep on {grid['workers']} workers: "
            f"{grid['wall_s']:.0f} s wall ({grid['per_curve_s']:.3f} s per curve; goal "
            f"{grid['goal_s']:.0f} s); statuses {grid['statuses']}"
        )
    save = REPORTS / "bench-unitcell.json" if args.save else None
    emit(record, as_json=args.json, text="\n".join(lines), save=save)
    return 0
