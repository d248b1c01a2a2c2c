"""``dpfexplore bench reset-model``: the fast reset-time model against the full model.

Held-out designs: the random metastable designs of ``bench dynamics`` (2-6 units, one or two
low domes, kept when the reference has a unit that resets; seed 7 by default, which no training
run uses) and the pick-and-place finger, all under 0.7 MPa, ``τ = (0, 1, 5, 5.1)`` s, 15 s
horizon. Reference: ``rodas4`` at ``atol = 1e-8`` mm (within ~1e-8 of SciPy's tight Radau, see
``bench dynamics``). Timed on one core: ``reset_times_batch(method="fast")`` on the whole
batch, fallbacks included (the median of three rounds, per design), beside ``rodas4`` at its
default tolerance on the same designs.

Errors are per unit: relative reset-time error over the units the reference resets after at
least 0.05 s (metastable), fallback units included (their error is the full model's); class
agreement over every unit of every design (never inverted / resets / stays inverted); coverage
of the 90 % interval over the same metastable units of the rows the fast model answered (a
fallback row's interval is the full model's value at zero width: a value, not an interval
claim; its error is counted above); the fallback rate over designs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ._common import REPORTS, count, emit, machine_info, median_time
from .dynamics import sample_metastable_designs

PULSE = (0.7, (0.0, 1.0, 5.0, 5.1))
T_END = 15.0
#: The pick-and-place finger's reset times (s) and the goal's tolerance on them.
PICKPLACE_TOLERANCE = 0.02
#: Goals of the fast reset model (a summary line says which are met).
GOALS = {
    "us_per_design": 50.0,
    "median_rel_err": 0.01,
    "p95_rel_err": 0.05,
    "max_rel_err": 0.20,
    "class_agreement": 0.995,
    "coverage_90": 0.88,
}


def register(subparsers) -> None:
    """Add ``bench reset-model``."""
    parser = subparsers.add_parser(
        "reset-model",
        help="fast reset-time model: time, errors, class agreement, coverage, fallbacks",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument("--designs", type=count(1), default=500, help="held-out random designs")
    parser.add_argument("--seed", type=int, default=7, help="seed of the held-out designs")
    parser.add_argument("--model", default=None, help="model file (default: the packaged one)")
    parser.add_argument(
        "--max-rel-halfwidth",
        type=float,
        default=None,
        help="fall back where a unit's interval is wider (relative)",
    )
    parser.add_argument(
        "--save", action="store_true", help=f"write bench-reset-model.json to {REPORTS}/"
    )
    parser.set_defaults(handler=run)


def classes(reset: np.ndarray) -> np.ndarray:
    """-1 never inverted (NaN), 0 stays inverted (inf), 1 resets (finite)."""
    return np.where(np.isnan(reset), -1, np.where(np.isinf(reset), 0, 1))


def compare(out: dict, ref: dict, n_units: np.ndarray) -> dict:
    """Per-unit errors, class agreement, coverage and fallback rate of ``out`` against ``ref``."""
    active = np.arange(ref["reset_time"].shape[1])[None, :] < n_units[:, None]
    t_ref = ref["reset_time"]
    t_out = out["reset_time"]
    with np.errstate(invalid="ignore"):
        meta = active & np.isfinite(t_ref) & (t_ref >= 0.05)
        rel = np.where(np.isfinite(t_out[meta]), np.abs(t_out[meta] / t_ref[meta] - 1.0), np.inf)
        claimed = meta & ~out["fallback"][:, None]
        covered = (out["reset_time_lo"][claimed] <= t_ref[claimed]) & (
            t_ref[claimed] <= out["reset_time_hi"][claimed]
        )
    agree = (classes(t_out) == classes(t_ref))[active]
    levels = (0.5, 0.9, 0.95, 0.99, 1.0)
    n_of_unit = np.broadcast_to(n_units[:, None], t_ref.shape)[meta]
    by_n = {int(n): float(np.median(rel[n_of_unit == n])) for n in np.unique(n_of_unit)}
    return {
        "median_rel_err": float(np.median(rel)) if rel.size else float("nan"),
        "p95_rel_err": float(np.quantile(rel, 0.95)) if rel.size else float("nan"),
        "max_rel_err": float(rel.max()) if rel.size else float("nan"),
        "class_agreement": float(agree.mean()),
        "coverage_90": float(covered.mean()) if covered.size else float("nan"),
        "coverage_units": int(covered.size),
        "fallback_rate": float(np.mean(out["fallback"])),
        "metastable_units": int(meta.sum()),
        "units": int(active.sum()),
        "class_mismatches": int((~agree).sum()),
        "rel_err_quantiles": {f"{q:g}": float(np.quantile(rel, q)) for q in levels}
        if rel.size
        else {},
        "median_rel_err_by_n_units": by_n,
        "within_1pct": float(np.mean(rel <= 0.01)) if rel.size else float("nan"),
    }


def _time(batch, profile, **kwargs) -> float:
    """Median seconds per design of one ``reset_times_batch`` call on one core."""
    import numba

    from ..solvers.dynamics.simulate import reset_times_batch

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        seconds = median_time(
            lambda: reset_times_batch(batch, profile, t_end=T_END, **kwargs),
            repeats=3,
            min_time=0.0,
        )
    finally:
        numba.set_num_threads(threads)
    return seconds / len(batch)


def reset_model_record(
    designs: int = 500, seed: int = 7, model=None, max_rel_halfwidth: float | None = None
) -> dict:
    """The reset model's figures on held-out designs: the dict ``bench surrogate`` embeds.

    Returns
    -------
    dict
        ``us_per_design``, ``median_rel_err``, ``p95_rel_err``, ``max_rel_err``,
        ``class_agreement``, ``coverage_90``, ``fallback_rate`` (the goals' measures, module
        docstring), plus the full model's time on the same designs, the pick-and-place finger's
        times and errors, the fallback reasons and the sizes.
    """
    from ..model.design import Design, DesignBatch
    from ..solvers.dynamics.fast_reset import FALLBACK_REASONS
    from ..solvers.dynamics.simulate import PressureProfile, reset_times_batch

    profile = PressureProfile.pulse(*PULSE)
    fast = {"method": "fast", "model": model, "max_rel_halfwidth": max_rel_halfwidth}
    batch, ref = sample_metastable_designs(designs, seed)
    out = reset_times_batch(batch, profile, t_end=T_END, **fast)
    record = compare(out, ref, batch.n_units)
    reasons = out["fallback_reason"]
    record["fallback_reasons"] = {
        text: int(((reasons & bit) != 0).sum()) for bit, text in FALLBACK_REASONS.items()
    }
    reset_times_batch(batch.take(np.arange(2)), profile, t_end=T_END)  # warm both paths
    record["us_per_design"] = _time(batch, profile, **fast) * 1e6
    record["full_model_us_per_design"] = _time(batch, profile) * 1e6
    record["speedup"] = record["full_model_us_per_design"] / record["us_per_design"]
    pick = Design(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    pick_batch = DesignBatch.from_designs([pick])
    pick_ref = reset_times_batch(pick_batch, profile, t_end=T_END, atol=1e-8)
    pick_out = reset_times_batch(pick_batch, profile, t_end=T_END, **fast)
    resets = np.isfinite(pick_ref["reset_time"][0])
    rel = np.abs(pick_out["reset_time"][0, resets] / pick_ref["reset_time"][0, resets] - 1.0)
    record["pickplace"] = {
        "reset_times": pick_out["reset_time"][0, :6].tolist(),
        "reference": pick_ref["reset_time"][0, :6].tolist(),
        "interval": [
            pick_out["reset_time_lo"][0, :6].tolist(),
            pick_out["reset_time_hi"][0, :6].tolist(),
        ],
        "max_rel_err": float(rel.max()),
        "fallback": bool(pick_out["fallback"][0]),
        "within_2pct": bool(rel.max() <= PICKPLACE_TOLERANCE),
    }
    record["designs"] = len(batch)
    record["seed"] = seed
    record["max_rel_halfwidth"] = max_rel_halfwidth
    record["goals_met"] = {
        "us_per_design": record["us_per_design"] <= GOALS["us_per_design"],
        **{k: record[k] <= v for k, v in GOALS.items() if k.endswith("_err")},
        "class_agreement": record["class_agreement"] >= GOALS["class_agreement"],
        "coverage_90": record["coverage_90"] >= GOALS["coverage_90"],
        "pickplace_within_2pct": record["pickplace"]["within_2pct"],
    }
    return record


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore bench reset-model``."""
    start = time.perf_counter()
    record = reset_model_record(args.designs, args.seed, args.model, args.max_rel_halfwidth)
    record = {
        "benchmark": "reset-model",
        **record,
        "wall_s": time.perf_counter() - start,
        "machine": machine_info(),
    }
    p = record["pickplace"]
    lines = [
        "reset-model: fast reset times vs the full model (rodas4, atol 1e-8 reference)",
        f"machine: {record['machine']['cpu']}, {record['machine']['cores']} cores; "
        f"{record['designs']} held-out random metastable designs (seed {record['seed']})",
        f"time per design, one core: fast {record['us_per_design']:.1f} µs (fallbacks "
        f"included), full model {record['full_model_us_per_design']:.1f} µs "
        f"({record['speedup']:.1f}x)",
        f"relative error over {record['metastable_units']} metastable units: median "
        f"{record['median_rel_err']:.2e}, p95 {record['p95_rel_err']:.2e}, max "
        f"{record['max_rel_err']:.2e}",
        f"class agreement {record['class_agreement']:.4%} ({record['class_mismatches']} of "
        f"{record['units']} units); 90 % interval coverage {record['coverage_90']:.1%}; "
        f"fallback rate {record['fallback_rate']:.1%}",
        "fallback reasons: "
        + (", ".join(f"{k}: {v}" for k, v in record["fallback_reasons"].items() if v) or "none"),
        "pick-and-place: "
        + ", ".join(
            f"{t:.4f} s (ref {r:.4f})"
            for t, r in zip(p["reset_times"], p["reference"], strict=True)
            if np.isfinite(r)
        )
        + f"; max rel err {p['max_rel_err']:.2e}",
        "goals met: "
        + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in record["goals_met"].items()),
    ]
    save = REPORTS / "bench-reset-model.json" if args.save else None
    if save is not None:
        lines.append(f"saved {save}")
    emit(record, as_json=args.json, text="\n".join(lines), save=save)
    return 0
