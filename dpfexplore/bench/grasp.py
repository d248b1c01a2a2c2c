"""``dpfexplore bench grasp``: one grasp, the sorting loop over many objects, the sorting map.

Cost: the warm median of one grasp (one state, one object: the fingers' equilibrium against the
disk, grown into place) and of one grasp with its payload (the pull-out); the sorting loop over
``--objects`` objects (diameters uniform between 0.4 and 1 times the open aperture, masses
uniform in 0-10 g) on all Numba threads; the sorting map of ``--map`` × ``--map`` points.
Goals (issue 33 §4): 5 ms, 30 s for 10^4 objects on 2 cores, 60 s for 100 × 100.
Error: grip force and payload at the default penetration tolerance (1e-4 mm) against the
tightest (1e-8 mm), for objects in each grasp state of the paper's gripper. Compile time is
measured in fresh processes with an empty Numba cache.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ._common import REPORTS, compile_line, count, emit, fresh_process_timings, machine_info

GOALS = {"grasp_ms": 5.0, "sort_1e4_s": 30.0, "map_100_s": 60.0}
#: Objects of the error check: one inside each grasp state's aperture range (mm).
ERROR_DIAMETERS = (38.0, 47.0, 65.0, 80.0)


def register(subparsers) -> None:
    """Add ``bench grasp``."""
    parser = subparsers.add_parser(
        "grasp",
        help="grasp and sorting: one grasp, 10^4 objects, the 100 x 100 map, tolerance error",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument("--objects", type=count(1), default=10_000, help="objects to sort")
    parser.add_argument("--map", type=count(2), default=100, help="sorting map points per axis")
    parser.add_argument("--seed", type=int, default=33, help="seed of the objects")
    parser.add_argument(
        "--no-compile", action="store_true", help="skip the fresh-process compile-time measurement"
    )
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"write the record to {REPORTS}/bench-grasp.json and its summary to bench-grasp.md",
    )
    parser.set_defaults(handler=run)


def _grasp_times(gripper) -> dict:
    from ..grasping.grasp import _disk, solve_state
    from ..grasping.setup import GraspOptions
    from ._common import median_time

    ctl = GraspOptions().controls(gripper.unit_params)
    disk = _disk(gripper, 47.0, gripper.default_depth(), 0.5)
    j = 2  # 11100: the 47 mm disk is between its aperture and the previous state's
    grasp_s = median_time(lambda: solve_state(gripper, j, disk, ctl, payload=False))
    payload_s = median_time(lambda: solve_state(gripper, j, disk, ctl))
    return {"grasp_ms": 1e3 * grasp_s, "grasp_with_payload_ms": 1e3 * payload_s}


def _tolerance_error(gripper) -> dict:
    """Largest errors of grip force and payload at the default tolerance against 1e-8 mm."""
    from ..grasping.grasp import _disk, solve_state
    from ..grasping.setup import GraspOptions

    default, tight = GraspOptions(), GraspOptions(tol=1e-8)
    record = {"tol_mm": default.tol, "reference_tol_mm": tight.tol}
    for mu in (0.0, 0.5):
        rows = []
        for d in ERROR_DIAMETERS:
            disk = _disk(gripper, d, gripper.default_depth(), mu)
            for j in range(len(gripper.states)):
                a = solve_state(gripper, j, disk, default.controls(gripper.unit_params))
                b = solve_state(gripper, j, disk, tight.controls(gripper.unit_params))
                if b[2][3] > 0:  # G_GRIP: in contact at the tightest tolerance
                    rows.append((a[2][3], b[2][3], a[3], b[3]))
        grip = np.array([(r[0], r[1]) for r in rows])
        pay = np.array([(r[2], r[3]) for r in rows])
        record[f"mu_{mu:g}"] = {
            "grasps_in_contact": len(rows),
            "grip_max_abs_err_N": float(np.max(np.abs(grip[:, 0] - grip[:, 1]))),
            "grip_max_rel_err": float(np.max(np.abs(grip[:, 0] / grip[:, 1] - 1))),
            "payload_max_abs_err_N": float(np.max(np.abs(pay[:, 0] - pay[:, 1]))),
            "payload_max_rel_err": float(
                np.max(np.abs(pay[:, 0] - pay[:, 1]) / np.maximum(pay[:, 1], 1e-12))
            ),
        }
    return record


COMPILE_PROBE = """
import time
import numpy as np
from dpfexplore.examples import example_path
from dpfexplore.grasping import GraspOptions, grasp, gripper_of
from dpfexplore.grasping.sort import run_sort
from dpfexplore.model.design import load_design
t = time.process_time()
g = gripper_of(load_design(example_path("gripper")))
grasp(g, 47.0, mu=0.5)
run_sort(g, np.array([47.0]), np.array([0.01]), mu=0.5, depth=g.default_depth(),
         threshold=g.threshold(0.1), tip_lasts=True, options=GraspOptions())
print(time.process_time() - t)
"""


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench grasp``."""
    import numba

    from ..examples import example_path
    from ..grasping import gripper_of
    from ..grasping.setup import GRAVITY, GraspOptions
    from ..grasping.sort import run_sort, sorting_map
    from ..model.design import load_design

    gripper = gripper_of(load_design(example_path("gripper")))
    record: dict = {"benchmark": "grasp", "machine": machine_info(), "goals": GOALS}
    record["one_grasp"] = _grasp_times(gripper)
    rng = np.random.default_rng(args.seed)
    diameters = rng.uniform(0.4, 1.0, args.objects) * gripper.open_aperture
    masses = rng.uniform(0.0, 0.01, args.objects)
    common = {
        "mu": 0.5,
        "depth": gripper.default_depth(),
        "threshold": gripper.threshold(0.1),
        "tip_lasts": True,
        "options": GraspOptions(),
    }
    run_sort(gripper, diameters[:2], masses[:2] * GRAVITY, **common)  # loaded, threads up
    start = time.perf_counter()
    table = run_sort(gripper, diameters, masses * GRAVITY, **common)
    sort_s = time.perf_counter() - start
    record["sort"] = {
        "objects": args.objects,
        "threads": numba.get_num_threads(),
        "seconds": sort_s,
        "per_object_ms": 1e3 * sort_s / args.objects,
        "failed": int(np.sum(table[:, 5] != 0)),
        "scaled_to_1e4_s": sort_s * 1e4 / args.objects,
    }
    grid_d = np.linspace(0.4 * gripper.open_aperture, gripper.open_aperture, args.map)
    grid_m = np.linspace(0.0, 0.01, args.map)
    start = time.perf_counter()
    sorting_map(gripper, grid_d, grid_m, mu=0.5)
    record["map"] = {"points": [args.map, args.map], "seconds": time.perf_counter() - start}
    record["tolerance_error"] = _tolerance_error(gripper)
    if args.no_compile:
        record.update({"compile_s": None, "cache_load_s": None})
    else:
        cold, warm = fresh_process_timings(COMPILE_PROBE)
        record["compile_s"] = cold[0]
        record["cache_load_s"] = warm[0]
    text = _text(record)
    save = Path(REPORTS) / "bench-grasp.json" if args.save else None
    emit(record, as_json=args.json, text=text, save=save)
    if save is not None:
        from ..io.files import atomic_write

        atomic_write(save.with_suffix(".md"), _markdown(record, text))
    return 0


def _text(record: dict) -> str:
    g, s, m, e = record["one_grasp"], record["sort"], record["map"], record["tolerance_error"]
    mach = record["machine"]
    return "\n".join(
        [
            f"bench grasp on {mach['cpu']} ({mach['cores']} cores, {s['threads']} Numba threads)",
            f"one grasp (11100, 47 mm): {g['grasp_ms']:.2f} ms warm median (goal <= 5 ms); with "
            f"its payload {g['grasp_with_payload_ms']:.2f} ms",
            f"sort {s['objects']} objects: {s['seconds']:.2f} s ({s['per_object_ms']:.2f} ms "
            f"each; {s['scaled_to_1e4_s']:.1f} s per 10^4, goal <= 30 s), {s['failed']} failed",
            f"sorting map {m['points'][0]} x {m['points'][1]}: {m['seconds']:.2f} s "
            "(goal <= 60 s for 100 x 100)",
            *(
                f"tolerance {e['tol_mm']:g} mm against {e['reference_tol_mm']:g} mm, mu {mu}: "
                f"{e[k]['grasps_in_contact']} grasps, grip force "
                f"{e[k]['grip_max_abs_err_N']:.2e} N ({100 * e[k]['grip_max_rel_err']:.3f} %), "
                f"payload {e[k]['payload_max_abs_err_N']:.2e} N "
                f"({100 * e[k]['payload_max_rel_err']:.3f} %)"
                for mu, k in (("0", "mu_0"), ("0.5", "mu_0.5"))
            ),
            compile_line(record),
        ]
    )


def _markdown(record: dict, text: str) -> str:
    return (
        f"# bench grasp, {record['machine']['date']}\n\n"
        "`dpfexplore bench grasp --save` (the record: `bench-grasp.json`). The gripper example "
        "(the paper's), mu = 0.5, the default depth and threshold.\n\n```\n" + text + "\n```\n"
    )
