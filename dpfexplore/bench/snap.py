"""``dpfexplore bench snap``: snap pressures by continuation, their cost and the slow-ramp limit.

Cost: per design, the median over ``--rounds`` rounds through all designs of one
:func:`~dpfexplore.solvers.snap.continuation.snap_pressures` call on one core (rising ramp to
``--P-max`` from the flat finger, no dense re-check), without and with the release of every visited
state, for the gripper finger and random designs of the paper's box for each N; and the mean per
design of one :func:`~dpfexplore.solvers.snap.continuation.snap_pressures_batch` call on all cores.
Baseline: one slow-ramp simulation of the same design (Rodas4, a linear ramp to ``--P-max`` over
the longest duration below), which is what a user would run without the continuation, and which
still lags the quasi-static pressures.

Agreement: for the gripper and ``--ramp-designs`` random designs, each unit's first-inversion
pressure in slow-ramp simulations of durations 20, 200 and 2000 s against the continuation's:
the largest lag per duration, the final states that differ, and the exponent of lag against
ramp rate between the two slowest (2/3 for a snap, the passage through the fold's ghost; 1 for
a smooth crossing). Compile time is measured in fresh processes with an empty Numba cache.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from ._common import REPORTS, count, emit, fresh_process_timings, machine_info, median_time

#: Ramp durations (s) of the slow-ramp simulations.
DURATIONS = (20.0, 200.0, 2000.0)
#: The paper's design box (MODEL.md §2).
BOX = {
    "H": (3.0, 5.0),
    "U_L": (5.5, 10.0),
    "U_sep": (1.0, 5.0),
    "t": (0.5, 1.0),
    "t_lim": (1.0, 2.0),
}


def register(subparsers) -> None:
    """Add ``bench snap``."""
    parser = subparsers.add_parser(
        "snap",
        help="snap pressures: cost per design and agreement with slow-ramp simulations",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--units",
        type=_unit_list,
        default=(2, 4, 6, 8),
        help="finger sizes N, comma-separated (default 2,4,6,8)",
    )
    parser.add_argument("--designs", type=count(1), default=40, help="random designs per N")
    parser.add_argument(
        "--ramp-designs",
        type=count(1),
        default=8,
        help="random designs (N = 2-4) checked against slow ramps",
    )
    parser.add_argument("--P-max", type=float, default=0.8, help="top of the ramp, MPa")
    parser.add_argument(
        "--rounds", type=count(1), default=3, help="timing rounds through all designs"
    )
    parser.add_argument("--seed", type=int, default=2024, help="seed of the sampled designs")
    parser.add_argument(
        "--no-compile", action="store_true", help="skip the fresh-process compile-time measurement"
    )
    parser.add_argument(
        "--save", action="store_true", help=f"write the record to {REPORTS}/bench-snap.json"
    )
    parser.set_defaults(handler=run)


def _unit_list(text: str) -> tuple[int, ...]:
    """``--units``: comma-separated numbers of units (argparse reports a bad value)."""
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give comma-separated integers") from None


def random_designs(rng: np.random.Generator, n_units: int, count: int):
    """Designs drawn uniformly from the paper's box (independent heights)."""
    from ..model.design import Design

    designs = []
    for _ in range(count):
        per_unit = {key: list(rng.uniform(*BOX[key], n_units)) for key in ("H", "U_L", "U_sep")}
        shared = {key: float(rng.uniform(*BOX[key])) for key in ("t", "t_lim")}
        designs.append(Design(**per_unit, **shared))
    return designs


def _per_design_times(designs, p_max: float, rounds: int, release: bool) -> list[float]:
    """Per design, the median over ``rounds`` passes through all designs (s)."""
    from ..solvers.snap.continuation import snap_pressures

    samples: list[list[float]] = [[] for _ in designs]
    for _ in range(rounds):
        for i, design in enumerate(designs):
            start = time.perf_counter()
            snap_pressures(design, P_max=p_max, release=release, verify=False)
            samples[i].append(time.perf_counter() - start)
    return [statistics.median(s) for s in samples]


def _cost(designs, p_max: float, rounds: int) -> dict:
    from ..model.design import DesignBatch
    from ..solvers.snap.continuation import snap_pressures, snap_pressures_batch

    up = _per_design_times(designs, p_max, rounds, release=False)
    both = _per_design_times(designs, p_max, rounds, release=True)
    batch = DesignBatch.from_designs(designs)
    batch_s = median_time(lambda: snap_pressures_batch(batch, P_max=p_max), repeats=3, min_time=0.0)
    seqs = [snap_pressures(d, P_max=p_max, release=False, verify=False) for d in designs]
    return {
        "designs": len(designs),
        "median_ms": 1e3 * float(np.median(up)),
        "p90_ms": 1e3 * float(np.percentile(up, 90)),
        "median_ms_with_release": 1e3 * float(np.median(both)),
        "batch_mean_ms_with_release": 1e3 * batch_s / len(designs),
        "mean_snaps": float(np.mean([len(s.snaps) for s in seqs])),
        "mean_crossings": float(np.mean([len(s.events) - len(s.snaps) for s in seqs])),
        "failed": int(sum(s.status != 0 for s in seqs)),
    }


def _ramp_agreement(designs, p_max: float) -> dict:
    """Lags of slow-ramp simulations behind the continuation, per duration."""
    from ..solvers.dynamics.simulate import PressureProfile, simulate
    from ..solvers.snap.continuation import snap_pressures

    lags = {T: [] for T in DURATIONS}
    state_mismatch = {T: 0 for T in DURATIONS}
    exponents = []
    sim_s = []
    step_us = []
    for design in designs:
        seq = snap_pressures(design, P_max=p_max, release=False)
        inv = seq.inversion_pressures()
        per_t = {}
        for T in DURATIONS:
            start = time.perf_counter()
            run = simulate(design, PressureProfile([0.0, T], [0.0, p_max]), t_end=T, n_samples=0)
            if T == DURATIONS[-1]:
                sim_s.append(time.perf_counter() - start)
                step_us.append(1e6 * sim_s[-1] / max(1, run.stats["steps"] + run.stats["rejected"]))
            sim = run.snap_through * p_max / T
            both = np.isfinite(inv) & np.isfinite(sim)
            lag = sim[both] - inv[both]
            per_t[T] = lag
            lags[T].extend(lag.tolist())
            # no-contact units: the continuation reports their micro-snap and flags it, the
            # simulation classes them no_contact with a 0 bit (MODEL.md §3): not compared
            state_mismatch[T] += any(
                a != b
                for a, b, loose in zip(
                    run.final_state, seq.visits[-1].state, seq.no_contact, strict=True
                )
                if not loose
            )
        slow, slower = per_t[DURATIONS[-2]], per_t[DURATIONS[-1]]
        good = (slow > 0) & (slower > 0)
        exponents.extend(np.log10(slow[good] / slower[good]).tolist())
    return {
        "designs": len(designs),
        "durations_s": list(DURATIONS),
        "max_lag_MPa": [float(np.max(np.abs(lags[T]))) if lags[T] else None for T in DURATIONS],
        "median_lag_MPa": [float(np.median(lags[T])) if lags[T] else None for T in DURATIONS],
        "final_state_mismatches": [state_mismatch[T] for T in DURATIONS],
        "lag_exponent_median": float(np.median(exponents)) if exponents else None,
        "lag_exponent_range": (
            [float(min(exponents)), float(max(exponents))] if exponents else None
        ),
        "slowest_ramp_sim_ms_median": 1e3 * float(np.median(sim_s)),
        # machine speed today, against the README's Rodas4 figures (~11 us per step at N = 6)
        "rodas4_us_per_step_median": float(np.median(step_us)),
    }


COMPILE_PROBE = """
import time
t0 = time.perf_counter()
from dpfexplore.examples import example_path
from dpfexplore.model.design import load_design
from dpfexplore.solvers.snap.continuation import snap_pressures
d = load_design(example_path("gripper"))
t1 = time.perf_counter()
snap_pressures(d, P_max=0.7)
print(time.perf_counter() - t1)
"""


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench snap``."""
    from ..examples import example_path
    from ..model.design import load_design

    units = args.units
    rng = np.random.default_rng(args.seed)
    gripper = load_design(example_path("gripper"))
    record: dict = {"benchmark": "snap", "machine": machine_info(), "P_max": args.P_max}
    record["gripper"] = _cost([gripper], args.P_max, max(args.rounds, 5))
    record["by_n_units"] = [
        {"n_units": n, **_cost(random_designs(rng, n, args.designs), args.P_max, args.rounds)}
        for n in units
    ]
    ramp_designs = [gripper] + [
        d for n in (2, 3, 4) for d in random_designs(rng, n, args.ramp_designs // 3 + 1)
    ]
    ramp_designs = ramp_designs[: args.ramp_designs + 1]
    record["slow_ramp"] = _ramp_agreement(ramp_designs, args.P_max)
    record["slow_ramp_gripper"] = _ramp_agreement([gripper], args.P_max)
    g = record["gripper"]
    g["slow_ramp_sim_ms"] = record["slow_ramp_gripper"]["slowest_ramp_sim_ms_median"]
    g["speedup_vs_slow_ramp"] = g["slow_ramp_sim_ms"] / g["median_ms"]
    if not args.no_compile:
        cold, warm = fresh_process_timings(COMPILE_PROBE)
        record["compile_s"] = cold[0]
        record["cached_first_call_s"] = warm[0]
    save = Path(REPORTS) / "bench-snap.json" if args.save else None
    emit(record, as_json=args.json, text=_text(record), save=save)
    return 0


def _text(record: dict) -> str:
    lines = [
        f"snap pressures, rising ramp to {record['P_max']} MPa "
        f"({record['machine']['cpu']}, {record['machine']['date']})"
    ]
    g = record["gripper"]
    step_us = record["slow_ramp_gripper"]["rodas4_us_per_step_median"]
    lines.append(
        f"gripper: {g['median_ms']:.2f} ms per design, {g['median_ms_with_release']:.2f} "
        f"ms with releases; one slow-ramp simulation {g['slow_ramp_sim_ms']:.1f} ms "
        f"({g['speedup_vs_slow_ramp']:.0f}x); Rodas4 {step_us:.1f} us/step"
    )
    lines.append(
        f"{'N':>3} {'median ms':>10} {'p90 ms':>8} {'+release ms':>12} "
        f"{'batch ms':>9} {'snaps':>6} {'crossings':>9} {'failed':>6}"
    )
    for row in record["by_n_units"]:
        lines.append(
            f"{row['n_units']:>3} {row['median_ms']:>10.2f} {row['p90_ms']:>8.2f} "
            f"{row['median_ms_with_release']:>12.2f} "
            f"{row['batch_mean_ms_with_release']:>9.2f} {row['mean_snaps']:>6.1f} "
            f"{row['mean_crossings']:>9.1f} {row['failed']:>6}"
        )
    for name in ("slow_ramp_gripper", "slow_ramp"):
        r = record[name]
        lags = ", ".join(
            f"{T:g} s: {lag:.2e}" for T, lag in zip(r["durations_s"], r["max_lag_MPa"], strict=True)
        )
        lines.append(
            f"{name} ({r['designs']} designs): largest lag (MPa) {lags}; exponent "
            f"{r['lag_exponent_median']:.2f}; final states differing "
            f"(no-contact units aside) {r['final_state_mismatches']}"
        )
    if "compile_s" in record:
        lines.append(
            f"compile {record['compile_s']:.0f} s cold, first call "
            f"{record['cached_first_call_s']:.2f} s from the cache"
        )
    return "\n".join(lines)
