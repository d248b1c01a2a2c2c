"""``dpfexplore bench dynamics``: reset-time evaluation, every method against its error.

Two cases: the paper's pick-and-place finger (0.7 MPa, τ = 0, 1, 5, 5.1 s, 15 s horizon) and
random metastable designs (2-6 units, the paper's box with one or two low domes; kept when the
reference run has at least one unit that resets). For every integrator, tolerance and reduced
model it times :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch` on one core (per
design: the median over three rounds through all rows of the median of five calls; the SciPy
baseline on the pick-and-place finger: the median of three runs) and measures the reset times'
largest relative error against the reference, the number of units whose class (resets / never
resets) differs, and the final states that differ.

References: SciPy ``solve_ivp(method="Radau")`` at rtol 1e-7, atol 1e-10 for the
pick-and-place finger; for the random designs our Rodas4 at atol 1e-8 mm, itself checked
against that Radau on the first ``--radau-designs`` of them (the agreement is printed; SciPy's
Radau stalls with ~1e-12 s steps on some designs at such tolerances, and a run past
``MAX_NFEV`` evaluations is counted, not waited for). Radau rows are compared with the same
reference as ours. The baseline's time is
``solve_ivp(Radau)`` at the settings of ``reference/pickplace_dynamics.csv`` (rtol 1e-4, atol
1e-9) with the analytic Jacobian, on the same designs. The explicit ``dopri5`` on the full model
takes seconds per design, so it runs on the pick-and-place finger and ``--explicit-designs``
random ones (the overdamped dopri5 on ten times as many). Compile time is measured in fresh
processes with an empty Numba cache.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

from ._common import REPORTS, count, emit, fresh_process_timings, machine_info, median_time

#: (method, atol in mm or None for the default) rows of the time-vs-error table.
LADDER = (
    ("rodas4", 1e-2),
    ("rodas4", 1e-3),
    ("rodas4", 3e-4),
    ("rodas4", None),
    ("rodas4", 1e-5),
    ("rodas4-overdamped", 1e-3),
    ("rodas4-overdamped", None),
    ("release", 1e-3),
    ("release", None),
    ("dopri5-overdamped", None),
    ("dopri5", None),
)
#: SciPy Radau baselines: the settings of reference/pickplace_dynamics.csv, and a loose one to
#: compare at matched error.
RADAU_ROWS = (("scipy-radau", 1e-4, 1e-9), ("scipy-radau-loose", 1e-3, 1e-6))
PULSE = (0.7, (0.0, 1.0, 5.0, 5.1))
#: Rounds through all ladder rows when timing them (see :func:`_case`).
TIMING_ROUNDS = 3
#: Runs of the SciPy baseline on the pick-and-place finger (the median is the baseline).
RADAU_RUNS_PICKPLACE = 3
#: Evaluation cap of the SciPy runs (its Radau can stall; such a run counts as failed).
MAX_NFEV = 300_000
T_END = 15.0

logger = logging.getLogger(__name__)


def register(subparsers) -> None:
    """Add ``bench dynamics``."""
    parser = subparsers.add_parser(
        "dynamics",
        help="reset times: every integrator and reduced model, time vs error, vs SciPy Radau",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument("--designs", type=count(1), default=100, help="random metastable designs")
    parser.add_argument(
        "--radau-designs",
        type=count(1),
        default=10,
        help="random designs also run with SciPy Radau (baseline and check)",
    )
    parser.add_argument(
        "--explicit-designs",
        type=count(0),
        default=3,
        help="random designs run with the explicit full-model dopri5 "
        "(0 also skips it on the pick-and-place finger)",
    )
    parser.add_argument("--seed", type=int, default=2024, help="seed of the sampled designs")
    parser.add_argument(
        "--no-compile",
        action="store_true",
        help="skip the cold-compile measurement (two fresh processes)",
    )
    parser.add_argument(
        "--save", action="store_true", help=f"write bench-dynamics.json and .png to {REPORTS}/"
    )
    parser.set_defaults(handler=run)


def sample_metastable_designs(n_designs: int, seed: int):
    """Random fingers with one or two low (possibly metastable) domes, and a reference run.

    Returns the batch of designs whose reference has at least one unit that resets, and the
    reference outputs (Rodas4 at atol 1e-8 mm).
    """
    from ..model.design import MAX_UNITS, DesignBatch
    from ..solvers.dynamics.simulate import PressureProfile, reset_times_batch

    rng = np.random.default_rng(seed)
    profile = PressureProfile.pulse(*PULSE)
    kept = []
    refs = []
    while sum(len(b) for b in kept) < n_designs:
        m = max(8, 2 * (n_designs - sum(len(b) for b in kept)))
        n_units = rng.integers(2, 7, m)
        H = np.full((m, MAX_UNITS), np.nan)
        U_L = H.copy()
        U_sep = H.copy()
        for i in range(m):
            n = n_units[i]
            H[i, :n] = rng.uniform(3.0, 5.0, n)
            low = rng.choice(n, size=min(n, rng.integers(1, 3)), replace=False)
            H[i, low] = rng.uniform(2.6, 3.2, low.size)
            U_L[i, :n] = rng.uniform(5.5, 10.0)
            U_sep[i, :n] = rng.uniform(1.0, 2.0)
        batch = DesignBatch(
            n_units=n_units,
            H=H,
            U_L=U_L,
            U_sep=U_sep,
            t=rng.uniform(0.75, 1.0, m),
            t_lim=rng.uniform(1.0, 2.0, m),
            E=26.0,
            nu=0.35,
            r_b=5.0,
            t_ch=1.0,
        )
        batch = batch.take(np.flatnonzero(batch.status() == 0))
        start = time.perf_counter()
        ref = reset_times_batch(batch, profile, t_end=T_END, atol=1e-8)
        logger.info(
            "reference runs: %d candidates, %.1f s", len(batch), time.perf_counter() - start
        )
        resets = np.isfinite(ref["reset_time"]).any(axis=1) & (ref["status"] == 0)
        keep = np.flatnonzero(resets)
        kept.append(batch.take(keep))
        refs.append({k: v[keep] for k, v in ref.items()})
    ref = {k: np.concatenate([r[k] for r in refs])[:n_designs] for k in refs[0]}
    return DesignBatch.concatenate(kept).take(np.arange(len(ref["status"]))), ref


def _errors(out, ref) -> dict:
    """Reset-time errors against the reference; class and final-state mismatches.

    The relative error is over metastable units (reference reset time >= 0.05 s): a monostable
    unit resets within milliseconds of the release (sometimes before its end, a negative
    time), where a relative error says little; those count in the absolute error.
    """
    both = np.isfinite(ref["reset_time"]) & np.isfinite(out["reset_time"])
    meta = both & (np.abs(ref["reset_time"]) >= 0.05)
    rel = np.abs(out["reset_time"][meta] - ref["reset_time"][meta]) / ref["reset_time"][meta]
    absolute = np.abs(out["reset_time"][both] - ref["reset_time"][both])
    ref_resets = np.isfinite(ref["reset_time"])
    out_resets = np.isfinite(out["reset_time"])
    ref_never = np.isinf(ref["reset_time"])
    class_mismatch = int(
        ((ref_resets & ~out_resets) | (ref_never & ~np.isinf(out["reset_time"]))).sum()
    )
    return {
        "reset_time_rel_err": float(rel.max()) if rel.size else float("nan"),
        "reset_time_rel_err_median": float(np.median(rel)) if rel.size else float("nan"),
        "reset_time_abs_err_s": float(absolute.max()) if absolute.size else float("nan"),
        "metastable_units": int(meta.sum()),
        "class_mismatches": class_mismatch,
        "state_mismatches": int((out["final_state"] != ref["final_state"]).sum()),
        "failed": int((out["status"] != 0).sum()),
    }


def _outputs(batch, profile, method, atol) -> dict:
    from ..solvers.dynamics.simulate import reset_times_batch

    return reset_times_batch(batch, profile, t_end=T_END, method=method, atol=atol)


def _time_method(batch, profile, method, atol, *, repeats) -> float:
    """Median seconds per design on one core over ``repeats`` calls."""
    import numba

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        seconds = median_time(
            lambda: _outputs(batch, profile, method, atol), repeats=repeats, min_time=0.0
        )
    finally:
        numba.set_num_threads(threads)
    return seconds / len(batch)


def _radau(designs, profile, *, rtol, atol) -> tuple[list[float], list]:
    from ..solvers.dynamics.scipy_baseline import simulate_scipy

    seconds, results = [], []
    for design in designs:
        start = time.perf_counter()
        results.append(
            simulate_scipy(
                design, profile, t_end=T_END, rtol=rtol, atol=atol, n_samples=0, max_nfev=MAX_NFEV
            )
        )
        seconds.append(time.perf_counter() - start)
        logger.info("Radau rtol=%g atol=%g N=%d: %.2f s", rtol, atol, design.n_units, seconds[-1])
    return seconds, results


def _as_batch_output(results, n_max=12) -> dict:
    n = len(results)
    out = {
        "reset_time": np.full((n, n_max), np.nan),
        "final_state": np.zeros(n, dtype=np.int64),
        "status": np.zeros(n, dtype=np.int8),
    }
    for i, r in enumerate(results):
        out["reset_time"][i, : r.design.n_units] = r.reset_time
        out["final_state"][i] = int(r.final_state, 2)
        out["status"][i] = int(r.status)
    return out


def _compile_seconds() -> dict[str, float]:
    """Cold compile and warm cache-load of the dynamics kernels, each in a fresh process."""
    probe = """
        import time
        t0 = time.perf_counter()
        from dpfexplore.model.design import Design, DesignBatch
        from dpfexplore.solvers.dynamics.simulate import PressureProfile, reset_times_batch
        batch = DesignBatch.from_designs([Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83,
                                                 t_lim=1.0)])
        profile = PressureProfile.pulse(0.7, (0.0, 0.01, 0.02, 0.03))
        t1 = time.perf_counter()
        reset_times_batch(batch, profile, t_end=0.04)
        t2 = time.perf_counter()
        reset_times_batch(batch, profile, t_end=0.04, method="release")
        print(t1 - t0, t2 - t1, time.perf_counter() - t2)
        """
    cold, warm = fresh_process_timings(probe)
    return {"import_s": cold[0], "compile_s": cold[1] + cold[2], "cache_load_s": warm[1] + warm[2]}


def _case(name, batch, ref, profile, radau, *, explicit_rows) -> list[dict]:
    """Every ladder row on one set of designs; ``radau`` maps labels to (rtol, atol, s, errors).

    Each row's time is the median over :data:`TIMING_ROUNDS` rounds through all rows (the slow
    explicit rows: one round), so that a burst of load from other tenants of a shared machine
    moves a sample of every row instead of all the samples of one.
    """
    from ..solvers.dynamics.simulate import METHODS

    radau_seconds = radau["scipy-radau"][2]
    rows = []
    for method, atol in LADDER:
        designs = batch
        sub_ref = ref
        # the explicit pair costs ~1e5x more on the full model, ~100x on the overdamped one
        limit = {"dopri5": explicit_rows, "dopri5-overdamped": 10 * explicit_rows}.get(method)
        if limit is not None and limit < len(batch):
            if limit == 0:
                continue
            designs = batch.take(np.arange(limit))
            sub_ref = {k: v[:limit] for k, v in ref.items()}
        start = time.perf_counter()
        out = _outputs(designs, profile, method, atol)
        logger.info(
            "%s %s atol=%s: %d designs, %.1f s",
            name,
            method,
            atol,
            len(designs),
            time.perf_counter() - start,
        )
        rows.append(
            (
                method,
                atol,
                designs,
                {
                    "case": name,
                    "method": method,
                    "atol_mm": atol if atol is not None else METHODS[method].atol,
                    "designs": len(designs),
                    **_errors(out, sub_ref),
                },
            )
        )
    samples = [[] for _ in rows]
    for round_ in range(TIMING_ROUNDS):
        for i, (method, atol, designs, _) in enumerate(rows):
            explicit = method.startswith("dopri5")
            if explicit and round_ > 0:
                continue
            samples[i].append(
                _time_method(designs, profile, method, atol, repeats=1 if explicit else 5)
            )
    records = []
    for (_, _, _, record), row_samples in zip(rows, samples, strict=True):
        seconds = float(np.median(row_samples))
        records.append(
            {**record, "us_per_design": seconds * 1e6, "speedup_vs_radau": radau_seconds / seconds}
        )
    for label, (rtol, atol, seconds, err) in radau.items():
        records.append(
            {
                "case": name,
                "method": label,
                "atol_mm": atol,
                "rtol": rtol,
                "us_per_design": seconds * 1e6,
                **err,
                "speedup_vs_radau": radau_seconds / seconds,
            }
        )
    return records


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore bench dynamics``."""
    from ..model.design import Design, DesignBatch
    from ..solvers.dynamics.simulate import PressureProfile

    profile = PressureProfile.pulse(*PULSE)
    compile_times = {} if args.no_compile else _compile_seconds()
    # warm this process's kernels before timing anything
    warm = DesignBatch.from_designs([Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)])
    for method, _ in LADDER:
        if not method.startswith("dopri5"):
            _time_method(warm, profile, method, None, repeats=1)

    # Case 1: the pick-and-place finger against tight Radau.
    pick = Design(
        H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0, name="pickplace"
    )
    pick_batch = DesignBatch.from_designs([pick])
    start = time.perf_counter()
    tight_seconds, tight = _radau([pick], profile, rtol=1e-7, atol=1e-10)
    pick_ref = _as_batch_output(tight)
    radau = {}
    for label, rtol, atol in RADAU_ROWS:
        seconds, runs = _radau([pick] * RADAU_RUNS_PICKPLACE, profile, rtol=rtol, atol=atol)
        radau[label] = (
            rtol,
            atol,
            float(np.median(seconds)),
            {**_errors(_as_batch_output(runs[:1]), pick_ref), "designs": 1},
        )
    records = _case(
        "pickplace",
        pick_batch,
        pick_ref,
        profile,
        radau,
        explicit_rows=min(1, args.explicit_designs),
    )

    # Case 2: random metastable designs against tight Rodas4, checked by tight Radau.
    batch, ref = sample_metastable_designs(args.designs, args.seed)
    n_radau = min(args.radau_designs, len(batch))
    designs = [batch.design(i) for i in range(n_radau)]
    check_seconds, check = _radau(designs, profile, rtol=1e-7, atol=1e-10)
    check_out = _as_batch_output(check)
    checked = np.flatnonzero(check_out["status"] == 0)
    reference_check = _errors(
        {k: v[checked] for k, v in ref.items()}, {k: v[checked] for k, v in check_out.items()}
    )
    reference_check["radau_failed"] = int(n_radau - checked.size)
    ref_head = {k: v[:n_radau] for k, v in ref.items()}
    radau = {}
    for label, rtol, atol in RADAU_ROWS:
        seconds, runs = _radau(designs, profile, rtol=rtol, atol=atol)
        radau[label] = (
            rtol,
            atol,
            float(np.median(seconds)),
            {**_errors(_as_batch_output(runs), ref_head), "designs": n_radau},
        )
    records += _case("random", batch, ref, profile, radau, explicit_rows=args.explicit_designs)
    elapsed = time.perf_counter() - start

    record = {
        "benchmark": "dynamics",
        "records": records,
        "radau_baseline_us_per_design": {
            r["case"]: r["us_per_design"] for r in records if r["method"] == "scipy-radau"
        },
        "error_measure": "reset_time_rel_err: max over metastable units (reference reset "
        ">= 0.05 s) of |T - T_ref| / T_ref; reset_time_abs_err_s: max over all units that reset",
        "tight_radau_seconds_pickplace": tight_seconds[0],
        "reference_check_random": {
            **reference_check,
            "designs": n_radau,
            "radau_tight_seconds_median": float(np.median(check_seconds)),
        },
        "random_designs": len(batch),
        "units_per_design": np.bincount(batch.n_units).tolist(),
        **compile_times,
        "wall_s": elapsed,
        "machine": machine_info(),
    }
    lines = [
        "dynamics: reset-time evaluation per design on one core (median), error vs tight reference",
        f"machine: {record['machine']['cpu']}, {record['machine']['cores']} cores; "
        f"{len(batch)} random metastable designs (N = 2-6)",
        (
            f"compile (cold cache) {compile_times['compile_s']:.1f} s, cache load "
            f"{compile_times['cache_load_s']:.2f} s"
            if compile_times
            else "compile: not measured"
        ),
        f"random-set reference (Rodas4 atol 1e-8) vs Radau rtol 1e-7 on {n_radau} designs: "
        f"max rel err {reference_check['reset_time_rel_err']:.1e}, "
        f"class mismatches {reference_check['class_mismatches']}, "
        f"Radau stalled on {reference_check['radau_failed']}",
        "errors: relative over metastable units (reset >= 0.05 s), absolute over all",
        f"{'case':>9} {'method':>18} {'atol mm':>8} {'µs/design':>11} {'max rel err':>12} "
        f"{'median':>9} {'abs err s':>9} {'class≠':>6} {'state≠':>6} {'fail':>4} {'vs Radau':>9}",
    ]
    for r in records:
        lines.append(
            f"{r['case']:>9} {r['method']:>18} {r['atol_mm']:>8.0e} {r['us_per_design']:>11.0f} "
            f"{r['reset_time_rel_err']:>12.1e} {r['reset_time_rel_err_median']:>9.1e} "
            f"{r['reset_time_abs_err_s']:>9.1e} {r['class_mismatches']:>6} "
            f"{r['state_mismatches']:>6} {r['failed']:>4} {r['speedup_vs_radau']:>8.0f}x"
        )
    save = None
    if args.save:
        save = REPORTS / "bench-dynamics.json"
        _plot(records, REPORTS / "bench-dynamics.png")
        lines.append(f"saved {save} and {REPORTS / 'bench-dynamics.png'}")
    emit(record, as_json=args.json, text="\n".join(lines), save=save)
    return 0


def _plot(records, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.5), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, case in zip(axes, ("pickplace", "random"), strict=True):
        rows = [r for r in records if r["case"] == case]
        methods = sorted({r["method"] for r in rows})
        for i, method in enumerate(methods):
            mine = sorted((r for r in rows if r["method"] == method), key=lambda r: r["atol_mm"])
            ax.loglog(
                [r["us_per_design"] for r in mine],
                [max(r["reset_time_rel_err"], 1e-9) for r in mine],
                marker="o",
                color=f"C{i}",
                label=method,
            )
        ax.set_xlabel("time per design, one core (µs)")
        ax.set_ylabel("max relative reset-time error")
        ax.set_title(
            {"pickplace": "pick-and-place finger", "random": "random metastable designs"}[case]
        )
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
