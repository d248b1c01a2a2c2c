"""``dpfexplore bench sensitivities``: design sensitivities against finite differences, API costs.

Per finger size N, on designs of the paper's box whose domes are all bistable (the all-inverted
state, or the state it collapses to, kept where its softest mode is above 1e-3 N/mm, i.e. far
from a fold):

* the kernel cost of the sensitivities (all ``3N + 3`` parameters, every output and ``dx*/dθ``)
  against the kernel cost of the solve they come from, design by design (goal <= 2x); each
  design's time is its median over passes through all designs, so a burst of load from another
  tenant inflates one pass, not a design;
* the baseline: central finite differences of the solver through the API (``find_state`` at
  ``θ ± ε``, ``ε = 1e-5 |θ|``), timed, and its kernel floor (``2P`` kernel solves);
* errors of ours and of that baseline against a trusted reference: Richardson-extrapolated
  central differences of the solver at tight tolerance (steps ``2e-4`` and ``1e-4``), as the
  largest difference over parameters relative to each output's largest derivative, apart for
  tip, bend, curvature and energy and for the stiffness (whose reference is the noisier).

API costs: ``find_state`` per call on the paper's gripper (N = 5) and pick-and-place finger
(N = 6), with and without sensitivities, and ``solve_batch`` per design for batches of 1, 8 and
64 five-unit designs, each against the row kernel it runs on prepared tables (the compiled work
alone, without validation, packing and wrapping): the best of 40 rounds that alternate the two,
the least-disturbed estimate of fixed work on a machine whose load comes in bursts. Compile time
is measured in fresh processes with an empty Numba cache, apart from run times.

:func:`measure` returns the record (for other benchmarks to print these rows, e.g.
:func:`text_rows`).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numpy.typing import NDArray

from ..model.limits import MAX_UNITS
from ._common import (
    NOT_MEASURED,
    REPORTS,
    compile_line,
    count,
    emit,
    fresh_process_timings,
    int_list,
    machine_info,
)

#: Finger sizes measured by default.
UNITS = (2, 5, 8, 12)
#: Relative step of the baseline's central differences.
FD_STEP = 1e-5
#: Steps of the Richardson-extrapolated reference (mm; MPa for E: times E). The stiffness's
#: differences are noise-limited below this (its round-off, ~1e-10 relative in a Hessian whose
#: stiff posts and soft bending modes are six decades apart, over the step).
REFERENCE_STEP = 2e-4
#: A state is "far from a fold" when its softest mode is above this (N/mm).
MIN_EIG_FAR = 1e-3
#: Batch sizes of the solve_batch rows.
BATCH_SIZES = (1, 8, 64)


def register(subparsers) -> None:
    """Add ``bench sensitivities``."""
    parser = subparsers.add_parser(
        "sensitivities",
        help="design sensitivities vs finite differences; find_state / small-batch API costs",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--units",
        type=int_list(1, MAX_UNITS),
        default=",".join(map(str, UNITS)),
        help="finger sizes N (default 2,5,8,12)",
    )
    parser.add_argument("--designs", type=count(1), default=30, help="designs per N (timing)")
    parser.add_argument(
        "--reference-designs",
        type=count(1),
        default=5,
        help="designs per N checked against the finite-difference reference",
    )
    parser.add_argument("--seed", type=int, default=2025, help="seed of the sampled designs")
    parser.add_argument(
        "--no-compile",
        action="store_true",
        help="skip the compile-time measurement (two fresh processes)",
    )
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"also write the record to {REPORTS}/bench-sensitivities.json",
    )
    parser.set_defaults(handler=run)


def _perturbed(design, name: str, delta: float):
    values = design.to_dict()
    if name in ("t", "t_lim", "E"):
        values[name] += delta
    else:
        kind, _, unit = name.rpartition("_")
        column = list(values[kind])
        column[int(unit) - 1] += delta
        values[kind] = column
    return type(design)(**values)


def _parameter_value(design, name: str) -> float:
    if name in ("t", "t_lim", "E"):
        return float(getattr(design, name))
    kind, _, unit = name.rpartition("_")
    return float(getattr(design, kind)[int(unit) - 1])


def _outputs(design, state: str, options) -> np.ndarray | None:
    from ..solvers.statics import find_state

    r = find_state(design, state, options=options)
    if r.found != state:
        return None
    return np.array([r.tip[0], r.tip[1], r.bend_angle, r.curvature, r.energy, r.stiffness])


def central_differences(design, state: str, steps, options=None) -> np.ndarray | None:
    """Central differences of the solver's six outputs, shape (6, P); Richardson when two steps.

    ``steps`` maps a parameter to its step(s); None when a step changes the state.
    """
    from ..numerics.differences import central_differences as differences
    from ..solvers.sensitivities import parameter_names

    names = parameter_names(design.n_units)
    theta = np.array([_parameter_value(design, name) for name in names])
    chosen = [steps(name) for name in names]
    failed = []

    def outputs(rows: np.ndarray) -> np.ndarray:
        # one find_state per row through the public API: the baseline a user would write
        values = []
        for row in rows:
            changed = design
            for name, value, base in zip(names, row, theta, strict=True):
                if value != base:
                    changed = _perturbed(changed, name, value - base)
            out = _outputs(changed, state, options)
            failed.append(out is None)
            values.append(np.full(6, np.nan) if out is None else out)
        return np.array(values)

    centre = _outputs(design, state, options)
    if centre is None:
        return None
    jac = differences(
        outputs,
        theta,
        centre,
        step=np.array([s[0] for s in chosen]),
        richardson=all(len(s) == 2 for s in chosen),
    )
    return None if any(failed) else jac


def _reference_steps(design, name: str) -> list[float]:
    scale = design.E if name == "E" else 1.0
    return [REFERENCE_STEP * scale, REFERENCE_STEP / 2 * scale]


def _relative_error(values: np.ndarray, reference: np.ndarray) -> NDArray:
    """Per output: largest difference relative to its largest derivative (NaN if undefined)."""
    scale = np.abs(reference).max(axis=1) + 1e-300
    return np.abs(values - reference).max(axis=1) / scale


def _sample(n_units: int, n_designs: int, seed: int):
    """Designs and the states to differentiate (far from a fold), with their shapes."""
    from ..model import status as st
    from ..solvers.statics import solve_batch
    from .statics import sample_bistable_batch

    batch = sample_bistable_batch(n_units, 3 * n_designs, seed)
    cols = solve_batch(batch, "all_inverted", shapes=True)
    ok = (cols["status"] == st.OK) | (cols["status"] == st.COLLAPSED)
    keep = np.flatnonzero(ok & (cols["min_eig"] > MIN_EIG_FAR))[:n_designs]
    nf = 4 * n_units - 2
    return [(batch.design(int(i)), int(cols["found"][i]), cols["x"][i, :nf].copy()) for i in keep]


def bench_size(
    n_units: int, n_designs: int, n_reference: int, seed: int, passes: int = 5, repeats: int = 20
) -> dict:
    """Sensitivities of one finger size: kernel costs, the finite-difference baseline, errors."""
    from .._kernels.records import Lattice
    from .._kernels.sensitivity.batch import sensitivities_repeatedly
    from .._kernels.statics.batch import solve_repeatedly
    from ..solvers.lattice import design_kernel_tables
    from ..solvers.sensitivities import OUTPUTS
    from ..solvers.statics import DEFAULT_OPTIONS, SolverOptions, find_state, state_string

    controls = DEFAULT_OPTIONS.kernel_args()
    samples = _sample(n_units, n_designs, seed)
    prepared = []
    for design, state, x in samples:
        tables = design_kernel_tables(design, derivatives=True)
        up = tables.unit_params[0, :n_units].copy()
        dtab = tables.derivatives[0, :n_units].copy()
        h = float(tables.h[0])
        solve_repeatedly(Lattice(up, h), state, controls, True, False, 1)
        sensitivities_repeatedly(x, up, h, dtab, design.E, 1)
        prepared.append((up, h, state, x, dtab, design.E))
    t_solve = np.empty((passes, len(prepared)))
    t_sens = np.empty((passes, len(prepared)))
    for k in range(passes):
        for i, (up, h, state, x, dtab, E) in enumerate(prepared):
            lattice = Lattice(up, h)
            start = time.perf_counter()
            solve_repeatedly(lattice, state, controls, True, False, repeats)
            t_solve[k, i] = (time.perf_counter() - start) / repeats
            start = time.perf_counter()
            sensitivities_repeatedly(x, up, h, dtab, E, repeats)
            t_sens[k, i] = (time.perf_counter() - start) / repeats
    solve_us = np.median(t_solve, axis=0) * 1e6
    sens_us = np.median(t_sens, axis=0) * 1e6
    n_params = 3 * n_units + 3

    tight = SolverOptions(xtol=1e-11)
    ours_err, fd_err, fd_us = [], [], []
    for design, state, _ in samples[:n_reference]:
        bits = state_string(state, n_units)
        result = find_state(design, bits, options=tight, sensitivities=True)
        ours = np.stack([result.sensitivities.of(name) for name in OUTPUTS])
        reference = central_differences(
            design,
            bits,
            lambda name: _reference_steps(design, name),  # noqa: B023
            tight,
        )
        start = time.perf_counter()
        baseline = central_differences(
            design,
            bits,
            lambda name: [FD_STEP * abs(_parameter_value(design, name))],  # noqa: B023
        )
        fd_us.append((time.perf_counter() - start) * 1e6)
        if reference is None or baseline is None:  # a step crossed into another state
            continue
        ours_err.append(_relative_error(ours, reference))
        fd_err.append(_relative_error(baseline, reference))
    ours_err = np.array(ours_err).reshape(-1, len(OUTPUTS))
    fd_err = np.array(fd_err).reshape(-1, len(OUTPUTS))
    stiffness = list(OUTPUTS).index("stiffness")
    shape = [j for j in range(len(OUTPUTS)) if j != stiffness]
    solve_med = float(np.median(solve_us))
    sens_med = float(np.median(sens_us))
    return {
        "n_units": n_units,
        "designs": len(samples),
        "parameters": n_params,
        "solve_us": solve_med,
        "sensitivities_us": sens_med,
        "ratio_median": float(np.median(sens_us / solve_us)),
        "ratio_p90": float(np.percentile(sens_us / solve_us, 90)),
        "fd_api_us": float(np.median(fd_us)) if fd_us else float("nan"),
        "fd_kernel_floor_us": 2 * n_params * solve_med,
        "speedup_vs_fd_api": float(np.median(fd_us)) / sens_med if fd_us else float("nan"),
        "speedup_vs_fd_kernel_floor": 2 * n_params * solve_med / sens_med,
        "reference_designs": len(ours_err),
        "ours_rel_err": _nanmax(ours_err[:, shape]),
        "fd_rel_err": _nanmax(fd_err[:, shape]),
        "ours_stiffness_rel_err": _nanmax(ours_err[:, stiffness]),
        "fd_stiffness_rel_err": _nanmax(fd_err[:, stiffness]),
    }


def _nanmax(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else float("nan")


def _interleaved(calls: dict, rounds: int = 40, min_time: float = 0.005) -> dict[str, float]:
    """Best time (s) per call of each function over ``rounds`` samples taken in alternation.

    The work of each call is fixed, so the least-disturbed sample is the best estimate of its
    cost on a shared machine whose load comes in bursts longer than a sample (medians of
    per-round ratios still read below 1 for identical work there); alternating the functions
    gives each the same chances of a quiet moment.
    """
    counts = {}
    for name, func in calls.items():
        n = 1
        while True:
            start = time.perf_counter()
            for _ in range(n):
                func()
            if time.perf_counter() - start >= min_time or n >= 1 << 16:
                break
            n *= 2
        counts[name] = n
    samples: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, func in calls.items():
            start = time.perf_counter()
            for _ in range(counts[name]):
                func()
            samples[name].append((time.perf_counter() - start) / counts[name])
    return {name: min(values) for name, values in samples.items()}


def _row_kernel(tables, states, *, sensitivities: bool, shape_derivatives: bool = False):
    """The serial row kernel :func:`solve_batch` runs, on prepared arrays, as a callable."""
    from .._kernels.sensitivity.batch import solve_rows_sensitivities_serial
    from .._kernels.statics.batch import solve_rows_serial
    from ..model.domain import MAX_UNITS
    from ..solvers.statics import DEFAULT_OPTIONS

    n_rows = len(states)
    nf = 4 * MAX_UNITS - 2
    # the records' fields as plain tuples, as solve_batch passes them (dpfexplore._kernels)
    args = (
        (tables.unit_params, tables.h, tables.n_units, tables.status),  # DesignTable
        (np.arange(n_rows, dtype=np.int64), np.asarray(states, dtype=np.int64), True, True),
        tuple(DEFAULT_OPTIONS.kernel_args()),  # NewtonControls
        (  # StateRows
            np.empty((n_rows, 11)),
            np.empty(n_rows, np.int8),
            np.empty(n_rows, np.int64),
            np.empty(n_rows, np.int32),
            np.empty((n_rows, nf if sensitivities else 0)),
        ),
    )
    if not sensitivities:
        return lambda: solve_rows_serial(*args)
    n_params = 3 * MAX_UNITS + 3
    sens = np.empty((n_rows, 6, n_params))
    dx = np.empty((n_rows, nf, n_params) if shape_derivatives else (0, 0, 0))
    derivatives = (tables.derivatives, tables.E)  # DesignDerivatives
    sens_rows = (sens, dx)  # SensitivityRows
    return lambda: solve_rows_sensitivities_serial(*args, derivatives, sens_rows)


def bench_api(seed: int) -> dict:
    """``find_state`` per call and ``solve_batch`` per design against the kernels they run.

    The kernel baseline is the serial row kernel on prepared tables: exactly the compiled work
    of the API call, without its validation, packing and result wrapping.
    """
    from ..examples import example_path
    from ..model.design import load_design
    from ..solvers.lattice import design_kernel_tables, kernel_tables
    from ..solvers.statics import find_state, parse_state, solve_batch
    from .statics import sample_bistable_batch

    rows = []
    for name, bits in (("gripper", "11110"), ("pickplace", "111100")):
        design = load_design(example_path(name))
        tables = design_kernel_tables(design, derivatives=True)
        state = [parse_state(bits, design.n_units)]
        t = _interleaved(
            {
                "api": lambda: find_state(design, bits),  # noqa: B023
                "kernel": _row_kernel(tables, state, sensitivities=False),
                "api_sens": lambda: find_state(design, bits, sensitivities=True),  # noqa: B023
                "kernel_sens": _row_kernel(
                    tables, state, sensitivities=True, shape_derivatives=True
                ),
            }
        )
        rows.append(
            {
                "design": name,
                "n_units": design.n_units,
                "state": bits,
                "find_state_us": t["api"] * 1e6,
                "kernel_us": t["kernel"] * 1e6,
                "ratio": t["api"] / t["kernel"],
                "find_state_sensitivities_us": t["api_sens"] * 1e6,
                "kernel_sensitivities_us": t["kernel_sens"] * 1e6,
                "ratio_sensitivities": t["api_sens"] / t["kernel_sens"],
            }
        )
    batch = sample_bistable_batch(5, max(BATCH_SIZES), seed)
    batches = []
    for size in BATCH_SIZES:
        sub = batch.take(np.arange(size))
        tables = kernel_tables(sub, derivatives=True)
        states = 2**sub.n_units - 1
        t = _interleaved(
            {
                "api": lambda: solve_batch(sub, "all_inverted"),  # noqa: B023
                "kernel": _row_kernel(tables, states, sensitivities=False),
                "api_sens": lambda: solve_batch(sub, "all_inverted", sensitivities=True),  # noqa: B023
                "kernel_sens": _row_kernel(tables, states, sensitivities=True),
            }
        )
        batches.append(
            {
                "batch": size,
                "solve_batch_us_per_design": t["api"] / size * 1e6,
                "kernel_us_per_design": t["kernel"] / size * 1e6,
                "ratio": t["api"] / t["kernel"],
                "solve_batch_sensitivities_us_per_design": t["api_sens"] / size * 1e6,
                "kernel_sensitivities_us_per_design": t["kernel_sens"] / size * 1e6,
                "ratio_sensitivities": t["api_sens"] / t["kernel_sens"],
            }
        )
    return {"find_state": rows, "solve_batch": batches}


def _compile_seconds() -> dict[str, float]:
    """Cold compile and warm cache-load times of the sensitivity path (fresh processes)."""
    (import_s, cold_s), (_, warm_s) = fresh_process_timings(
        """
        import time
        t0 = time.perf_counter()
        from dpfexplore import Design, DesignBatch, find_state, solve_batch
        design = Design(H=[4.0, 4.2], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.5)
        t1 = time.perf_counter()
        find_state(design, "11", sensitivities=True)
        solve_batch(DesignBatch.from_designs([design]), sensitivities=True)
        print(t1 - t0, time.perf_counter() - t1)
        """
    )
    return {"compile_s": cold_s, "cache_load_s": warm_s, "import_s": import_s}


def measure(
    units=UNITS,
    designs: int = 30,
    reference_designs: int = 5,
    seed: int = 2025,
    compile_time: bool = False,
) -> dict:
    """The benchmark's record: per-N sensitivity rows, API rows, machine, compile times."""
    compile_times = _compile_seconds() if compile_time else dict(NOT_MEASURED)
    by_n = [bench_size(n, designs, reference_designs, seed + n) for n in units]
    return {
        "by_n_units": by_n,
        "api": bench_api(seed),
        **compile_times,
        "machine": machine_info(),
    }


def text_rows(record: dict) -> list[str]:
    """The record as text lines (tables of the per-N rows and the API rows)."""
    lines = [
        "sensitivities (all 3N+3 parameters, 6 outputs and dx*/dθ) vs the solve they come from;"
        " kernel times on one core, median over designs",
        f"{'N':>3} {'P':>3} {'solve µs':>9} {'sens µs':>8} {'ratio':>6} {'p90':>5} "
        f"{'FD API µs':>10} {'FD floor µs':>11} {'ours err':>9} {'FD err':>8} "
        f"{'ours K err':>10} {'FD K err':>9}",
    ]
    for r in record["by_n_units"]:
        lines.append(
            f"{r['n_units']:>3} {r['parameters']:>3} {r['solve_us']:>9.1f} "
            f"{r['sensitivities_us']:>8.1f} {r['ratio_median']:>5.2f}x {r['ratio_p90']:>4.2f}x "
            f"{r['fd_api_us']:>10.0f} {r['fd_kernel_floor_us']:>11.0f} "
            f"{r['ours_rel_err']:>9.1e} {r['fd_rel_err']:>8.1e} "
            f"{r['ours_stiffness_rel_err']:>10.1e} {r['fd_stiffness_rel_err']:>9.1e}"
        )
    lines.append("API calls against the row kernel they run (best of 40 interleaved rounds)")
    lines.append(
        f"{'design':>10} {'N':>2} {'find_state µs':>13} {'kernel µs':>9} {'ratio':>6} "
        f"{'+sens µs':>9} {'kernel µs':>9} {'ratio':>6}"
    )
    for r in record["api"]["find_state"]:
        lines.append(
            f"{r['design']:>10} {r['n_units']:>2} {r['find_state_us']:>13.1f} "
            f"{r['kernel_us']:>9.1f} {r['ratio']:>5.2f}x {r['find_state_sensitivities_us']:>9.1f} "
            f"{r['kernel_sensitivities_us']:>9.1f} {r['ratio_sensitivities']:>5.2f}x"
        )
    lines.append(
        f"{'batch':>6} {'solve_batch µs/design':>21} {'kernel':>7} {'ratio':>6} "
        f"{'+sens':>7} {'kernel':>7} {'ratio':>6}"
    )
    for r in record["api"]["solve_batch"]:
        lines.append(
            f"{r['batch']:>6} {r['solve_batch_us_per_design']:>21.1f} "
            f"{r['kernel_us_per_design']:>7.1f} {r['ratio']:>5.2f}x "
            f"{r['solve_batch_sensitivities_us_per_design']:>7.1f} "
            f"{r['kernel_sensitivities_us_per_design']:>7.1f} {r['ratio_sensitivities']:>5.2f}x"
        )
    return lines


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore bench sensitivities``."""
    units = tuple(args.units)
    record = measure(
        units, args.designs, args.reference_designs, args.seed, compile_time=not args.no_compile
    )
    machine = record["machine"]
    header = [
        f"machine: {machine['cpu']}, {machine['cores']} cores; {machine['date']}",
        compile_line(record),
    ]
    emit(
        record,
        as_json=args.json,
        text="\n".join(header + text_rows(record)),
        save=REPORTS / "bench-sensitivities.json" if args.save else None,
    )
    return 0
