"""``dpfexplore bench identify``: identification speed and accuracy, ours against a plain fit.

The data are synthetic unit-cell curves drawn from the paper's constants set (so the answer is
known) on a grid of ``H``, ``t``, ``r_b`` and ``E``, 200 points each, with 1 % noise. Timed on one
core (BLAS limited to one thread): ours, the per-curve fits (linear start, robust bounded least
squares, covariance, flags) and the closed-form selection (grouped RFECV with ridge, lasso on
held-out geometries, OLS refit); the baseline, the paper's per-curve route: SciPy ``curve_fit``
of the energy law from a generic start. Errors: per-curve ``k_b`` and ``alpha`` against the truth
(median, max, failures), and the identified closed forms against the truth on geometries between
the grid points (median, max). The goal: 1,000 curves fitted and selected in at most 10 s.

Second part, the cost of running on a constants set: ``k_b``, ``alpha`` and the reach of a
million domes evaluated by the general path of every kernel table (the paper's set read as
data, :func:`~dpfexplore._kernels.tables.set_forms.set_constants_block`) against the paper's forms
compiled as plain arithmetic, side by side (medians of interleaved runs, compile apart), with
their largest difference; then the whole kernel-table build of a batch, the set's against the
same build with the compiled paper forms, and ``kernel_tables`` as users call it.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ._common import REPORTS, count, emit, machine_info

#: Seconds the whole identification of 1,000 curves may take on one core (the goal).
GOAL_S = 10.0


def register(subparsers) -> None:
    """Add ``bench identify``."""
    parser = subparsers.add_parser(
        "identify",
        help="identification: per-curve fits and closed-form selection vs SciPy curve_fit",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"also write the record to {REPORTS}/bench-identify.json",
    )
    parser.add_argument(
        "--heights", type=count(2), default=10, help="dome heights in the grid (3-5 mm)"
    )
    parser.add_argument(
        "--thicknesses", type=count(2), default=10, help="dome thicknesses in the grid (0.5-1 mm)"
    )
    parser.add_argument(
        "--baseline-curves", type=count(1), default=200, help="curves fitted by the baseline"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise")
    parser.add_argument(
        "--domes", type=count(1), default=1_000_000, help="domes of the table-build comparison"
    )
    parser.add_argument(
        "--repeats", type=count(1), default=7, help="interleaved runs of the table comparison"
    )
    parser.set_defaults(handler=run)


def _truth(curves):
    from ..model.constants_set import DEFAULT

    values = [DEFAULT.evaluate(c.H, c.t, c.r_b, c.E) for c in curves]
    return np.array([float(v["k_b"]) for v in values]), np.array(
        [float(v["alpha"]) for v in values]
    )


def _errors(found: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    error = np.abs(found / truth - 1.0)
    ok = np.isfinite(error)
    return {
        "median": float(np.median(error[ok])) if ok.any() else float("nan"),
        "max": float(np.max(error[ok])) if ok.any() else float("nan"),
        "failures": int((~ok).sum()),
    }


def _baseline(curves) -> tuple[float, np.ndarray, np.ndarray]:
    import warnings

    from scipy.optimize import OptimizeWarning, curve_fit

    from ..identification.spring_fit import spring_energy

    k_b, alpha = np.full(len(curves), np.nan), np.full(len(curves), np.nan)
    start = time.perf_counter()
    for i, c in enumerate(curves):
        x = c.displacement
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", OptimizeWarning)
                (k, a, _), _ = curve_fit(
                    spring_energy,
                    x,
                    c.energy,
                    p0=(1.0, 0.5, x.max() / 1.5),
                    bounds=([1e-9, 1e-9, 1e-9], [np.inf, 1.0, np.inf]),
                    maxfev=20_000,
                )
            k_b[i], alpha[i] = k, a
        except RuntimeError:  # no convergence within maxfev: a failure of the baseline
            pass
    return time.perf_counter() - start, k_b, alpha


def _table_build(n: int, repeats: int, seed: int) -> dict:
    """The constants of ``n`` domes: a set's general path against the compiled paper forms."""
    from .._kernels.layout import COL_KB, N_COLS
    from .._kernels.records import DesignArrays, TableOutputs
    from .._kernels.tables.design_tables import design_tables, empty_derivative_table
    from .._kernels.tables.form_loops import paper_forms, paper_tables, set_forms
    from ..model.constants_set import DEFAULT
    from ..model.design import DesignBatch
    from ..model.domain import MAX_UNITS
    from ..solvers.lattice import kernel_tables

    rng = np.random.default_rng(seed)
    H, t = rng.uniform(3.0, 5.0, n), rng.uniform(0.5, 1.0, n)
    r_b, E = np.full(n, 5.0), rng.uniform(5.0, 40.0, n)
    U_sep, t_ch = rng.uniform(1.0, 5.0, n), np.full(n, 1.0)
    forms = DEFAULT.kernel_forms()
    ours, paper = np.empty((n, 3)), np.empty((n, 3))
    start = time.perf_counter()
    set_forms(forms, H[:2], t[:2], r_b[:2], E[:2], U_sep[:2], t_ch[:2], ours[:2])
    compile_set = time.perf_counter() - start
    start = time.perf_counter()
    paper_forms(H[:2], t[:2], r_b[:2], E[:2], U_sep[:2], t_ch[:2], paper[:2])
    compile_paper = time.perf_counter() - start
    times: dict[str, list[float]] = {"set": [], "paper": []}
    for _ in range(repeats):
        start = time.perf_counter()
        set_forms(forms, H, t, r_b, E, U_sep, t_ch, ours)
        times["set"].append(time.perf_counter() - start)
        start = time.perf_counter()
        paper_forms(H, t, r_b, E, U_sep, t_ch, paper)
        times["paper"].append(time.perf_counter() - start)
    rel = np.abs(ours[:, :2] - paper[:, :2]) / np.abs(paper[:, :2])
    # the whole table build: designs of 6 units under the paper's set, its compiled kernel
    # against the same build with the compiled paper forms, and the call users make
    m = max(1, n // 6)
    per_unit = np.full((3, m, MAX_UNITS), np.nan)
    per_unit[0, :, :6] = H[: 6 * m].reshape(m, 6)
    per_unit[1, :, :6] = 8.0
    per_unit[2, :, :6] = U_sep[: 6 * m].reshape(m, 6)
    batch = DesignBatch(
        n_units=np.full(m, 6),
        H=per_unit[0],
        U_L=per_unit[1],
        U_sep=per_unit[2],
        t=t[:m],
        t_lim=1.5,
        E=E[:m],
        nu=0.35,
        r_b=5.0,
        t_ch=1.0,
    )
    designs = DesignArrays(*(getattr(batch, name) for name in DesignBatch.ARRAY_FIELDS))
    outputs = {
        name: TableOutputs(
            np.empty(m, dtype=np.int8),
            np.empty((m, MAX_UNITS, N_COLS)),
            np.empty(m),
            np.empty((m, MAX_UNITS), dtype=np.bool_),
            empty_derivative_table(),
        )
        for name in ("set", "paper")
    }
    builds = {
        # design_tables takes its records as plain tuples (dpfexplore._kernels)
        "set": lambda: design_tables(tuple(designs), forms, tuple(outputs["set"])),
        "paper": lambda: paper_tables(designs, forms, outputs["paper"]),
        "whole": lambda: kernel_tables(batch),
    }
    for build in builds.values():
        build()
    table_times: dict[str, list[float]] = {name: [] for name in builds}
    for _ in range(repeats):
        for name, build in builds.items():
            start = time.perf_counter()
            build()
            table_times[name].append(time.perf_counter() - start)
    table_set, table_paper = (float(np.median(table_times[k])) for k in ("set", "paper"))
    kb_set, kb_paper = (outputs[k].table[:, :6, COL_KB] for k in ("set", "paper"))
    set_s, paper_s = float(np.median(times["set"])), float(np.median(times["paper"]))
    return {
        "domes": n,
        "repeats": repeats,
        "set_median_s": set_s,
        "paper_median_s": paper_s,
        "ratio_set_over_paper": set_s / paper_s,
        "set_ns_per_dome": 1e9 * set_s / n,
        "paper_ns_per_dome": 1e9 * paper_s / n,
        "compile_set_s": compile_set,
        "compile_paper_s": compile_paper,
        "max_rel_difference_k_b": float(rel[:, 0].max()),
        "max_rel_difference_alpha": float(rel[:, 1].max()),
        "max_abs_difference_reach_mm": float(np.abs(ours[:, 2] - paper[:, 2]).max()),
        "table_build_designs": m,
        "table_build_median_s": float(np.median(table_times["whole"])),
        "tables_set_median_s": table_set,
        "tables_paper_median_s": table_paper,
        "ratio_tables_set_over_paper": table_set / table_paper,
        "tables_max_rel_difference_k_b": float(np.max(np.abs(kb_set / kb_paper - 1.0))),
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``bench identify``."""
    from threadpoolctl import threadpool_limits

    from ..identification.closed_forms import select_closed_form
    from ..identification.curves import curves_from_frame
    from ..identification.spring_fit import fit_curve
    from ..identification.synthetic import synthetic_curves
    from ..model.constants_set import DEFAULT

    H = np.linspace(3.0, 5.0, args.heights)
    t = np.linspace(0.5, 1.0, args.thicknesses)
    r_b, E = (4.8, 5.2), (8.0, 14.0, 20.0, 26.0, 40.0)
    frame = synthetic_curves(H, t, r_b, E, noise=0.01, points=200, seed=args.seed)
    curves = curves_from_frame(frame)
    with threadpool_limits(limits=1):
        start = time.perf_counter()
        fits = [fit_curve(c) for c in curves]
        fit_s = time.perf_counter() - start
        kb_fit = np.array([f.k_b for f in fits])
        alpha_fit = np.array([f.alpha for f in fits])
        geometry = np.array(["|".join(map(str, c.geometry)) for c in curves])
        Hs = np.array([c.H for c in curves])
        ts = np.array([c.t for c in curves])
        rbs = np.array([c.r_b for c in curves])
        Es = np.array([c.E for c in curves])
        R = (Hs**2 + rbs**2) / (2 * Hs)
        start = time.perf_counter()
        forms = {
            name: select_closed_form(ts / Hs, Hs / R, y, geometry)
            for name, y in (("k_hat", kb_fit * R / (Es * ts**2)), ("alpha", alpha_fit))
        }
        select_s = time.perf_counter() - start
        baseline_curves = curves[:: max(1, len(curves) // args.baseline_curves)][
            : args.baseline_curves
        ]
        baseline_s, kb_base, alpha_base = _baseline(baseline_curves)
    kb_true, alpha_true = _truth(curves)
    kb_base_true, alpha_base_true = _truth(baseline_curves)
    # the identified forms between the grid points (geometries no curve had)
    Hm, tm = np.meshgrid((H[:-1] + H[1:]) / 2, (t[:-1] + t[1:]) / 2)
    Rm = (Hm**2 + 25.0) / (2 * Hm)
    truth = DEFAULT.evaluate(Hm, tm, 5.0, 26.0)
    kb_form = 26.0 * tm**2 / Rm * forms["k_hat"].form(tm / Hm, Hm / Rm)
    alpha_form = forms["alpha"].form(tm / Hm, Hm / Rm)
    per_curve_ms = 1e3 * fit_s / len(curves)
    baseline_ms = 1e3 * baseline_s / len(baseline_curves)
    record = {
        "benchmark": "identify",
        "machine": machine_info(),
        "curves": len(curves),
        "points_per_curve": 200,
        "noise": 0.01,
        "fit_s": fit_s,
        "select_s": select_s,
        "total_s": fit_s + select_s,
        "goal_s": GOAL_S * len(curves) / 1000,
        "ours_ms_per_curve": per_curve_ms,
        "baseline_ms_per_curve": baseline_ms,
        "ratio_baseline_over_ours": baseline_ms / per_curve_ms,
        "flagged": sum(not f.ok for f in fits),
        "ours_k_b_error": _errors(kb_fit, kb_true),
        "ours_alpha_error": _errors(alpha_fit, alpha_true),
        "baseline_k_b_error": _errors(kb_base, kb_base_true),
        "baseline_alpha_error": _errors(alpha_base, alpha_base_true),
        "closed_form_k_b_error": _errors(kb_form, truth["k_b"]),
        "closed_form_alpha_error": _errors(alpha_form, truth["alpha"]),
        "terms": {name: len(s.form.exponents) for name, s in forms.items()},
        "heldout_winner": {name: s.heldout.get("winner") for name, s in forms.items()},
        "constants_tables": _table_build(args.domes, args.repeats, args.seed),
    }
    m = record["machine"]

    def pct(e):
        return (
            f"median {100 * e['median']:.3f} %, max {100 * e['max']:.3f} %, {e['failures']} failed"
        )

    text = "\n".join(
        [
            f"identify: {len(curves)} synthetic curves x 200 points, 1 % noise; one core",
            f"machine: {m['cpu']}, {m['cores']} cores; {m['date']}",
            f"ours: fits {fit_s:.2f} s ({per_curve_ms:.2f} ms per curve), selection "
            f"{select_s:.2f} s; total {fit_s + select_s:.2f} s (goal {record['goal_s']:.1f} s)",
            f"baseline curve_fit: {baseline_ms:.2f} ms per curve over {len(baseline_curves)} "
            f"curves ({record['ratio_baseline_over_ours']:.2f}x ours)",
            f"per-curve k_b error: ours {pct(record['ours_k_b_error'])}; baseline "
            f"{pct(record['baseline_k_b_error'])}",
            f"per-curve alpha error: ours {pct(record['ours_alpha_error'])}; baseline "
            f"{pct(record['baseline_alpha_error'])}",
            f"closed forms between grid points: k_b {pct(record['closed_form_k_b_error'])}; "
            f"alpha {pct(record['closed_form_alpha_error'])}",
            _tables_text(record["constants_tables"]),
        ]
    )
    save = REPORTS / "bench-identify.json" if args.save else None
    emit(record, as_json=args.json, text=text, save=save)
    return 0


def _tables_text(t: dict) -> str:
    return (
        f"constants of {t['domes']:,} domes (median of {t['repeats']}): set as data "
        f"{1e3 * t['set_median_s']:.1f} ms ({t['set_ns_per_dome']:.0f} ns/dome), paper forms "
        f"compiled {1e3 * t['paper_median_s']:.1f} ms ({t['paper_ns_per_dome']:.0f} ns/dome): "
        f"ratio {t['ratio_set_over_paper']:.2f}; compile {t['compile_set_s']:.2f} s / "
        f"{t['compile_paper_s']:.2f} s; largest difference k_b "
        f"{t['max_rel_difference_k_b']:.1e}, alpha {t['max_rel_difference_alpha']:.1e} "
        f"(relative), reach {t['max_abs_difference_reach_mm']:.1e} mm\n"
        f"kernel-table build, {t['table_build_designs']:,} designs of 6 units: set "
        f"{1e3 * t['tables_set_median_s']:.1f} ms, paper forms compiled "
        f"{1e3 * t['tables_paper_median_s']:.1f} ms: ratio {t['ratio_tables_set_over_paper']:.2f} "
        f"(k_b apart by {t['tables_max_rel_difference_k_b']:.1e}); kernel_tables() with its "
        f"allocations {1e3 * t['table_build_median_s']:.1f} ms"
    )
