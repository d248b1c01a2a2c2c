"""``dpfexplore bench surrogate``: surrogates of the paper's box against the exact model.

What it runs: the job ``jobs/surrogate-training.toml`` (the paper's design space, N = 2..7,
all units inverted; 20,000 designs per N) into a temporary directory, or ``--dataset DIR``;
:func:`dpfexplore.surrogates.fit.fit_surrogates` on it (a sixth of the designs held out
by ``design_id``, at most 100,000 training designs): held-out tip error per N of each surrogate
(nearest neighbours, gradient-boosted trees, MLP, Gaussian process, and the chain surrogate
that learns per-unit quantities and composes them exactly), the accuracy of the status
classifiers (gradient-boosted trees; the chain's rigid unit-cell rule), and the time per
prediction on one core, batched and single, beside the exact model (``solve_batch``) on the
same held-out designs. The goals (:data:`dpfexplore.surrogates.goals.GOALS`): tip median
<= 0.05 mm and p95 <= 0.3 mm, classifier >= 99 %, <= 100,000 training designs.

The fast reset-time model reports under ``reset_model``; see
:func:`reset_model_section`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path
from typing import Any

from ._common import REPORTS, count, emit, machine_info

JOBS = Path(__file__).resolve().parents[2] / "jobs"
OUTPUTS = ("tip_x", "tip_y", "curvature", "stiffness")
#: Where ``--save`` keeps the fitted surrogate of the benchmark run.
SAVED_MODEL = Path("results") / "surrogates" / "paper-box"


def register(subparsers) -> None:
    """Add ``bench surrogate``."""
    parser = subparsers.add_parser(
        "surrogate",
        help="surrogates of the paper's box: held-out error and speed against the exact model",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"also write {REPORTS}/bench-surrogate.json and .png, and the "
        f"fitted surrogate to {SAVED_MODEL}",
    )
    parser.add_argument(
        "--dataset", type=Path, help="use this sweep dataset instead of running the training job"
    )
    parser.add_argument(
        "--samples-per-n",
        type=count(1),
        help="designs per N of the training job (default: the job's 20000)",
    )
    parser.add_argument("--kinds", default="knn,gbt,mlp,gp,chain", help="regressor kinds")
    parser.add_argument("--classifiers", default="gbt,chain", help="status classifier kinds")
    parser.add_argument(
        "--params",
        type=json.loads,
        default=None,
        metavar="JSON",
        help="estimator keyword arguments per kind (JSON)",
    )
    parser.add_argument(
        "--reset-designs",
        type=count(1),
        default=500,
        metavar="N",
        help="held-out metastable designs of the reset-model section (default 500)",
    )
    parser.set_defaults(handler=run)


def reset_model_section(designs: int = 500) -> dict[str, Any]:
    """Figures of the fast reset-time model on held-out designs.

    ``{"reset_model": {"us_per_design", "median_rel_err", "p95_rel_err", "max_rel_err",
    "class_agreement", "coverage_90", "fallback_rate", ...}}`` from
    :func:`.reset_model.reset_model_record`, so one run of ``bench surrogate`` reports both
    parts of the surrogate question (flat surrogates and the fast reset model).
    """
    from .reset_model import reset_model_record

    return {"reset_model": reset_model_record(designs=designs)}


def _dataset(args: argparse.Namespace, tmp: Path) -> tuple[Path, dict[str, Any]]:
    """The training dataset: ``--dataset`` as given, else the training job run into ``tmp``."""
    if args.dataset is not None:
        return args.dataset, {"source": str(args.dataset)}
    from ..sweep.driver import run_sweep
    from ..sweep.job_file import load_job

    spec = load_job(JOBS / "surrogate-training.toml")
    if args.samples_per_n is not None:
        spec = dataclasses.replace(spec, samples_per_n=args.samples_per_n)
    out = tmp / "surrogate-training"
    summary = run_sweep(spec, out)
    return out, {
        "source": f"jobs/surrogate-training.toml, {spec.samples_per_n} per N",
        "designs": spec.n_designs,
        "sweep_s": summary.wall_s,
        "compile_s": summary.timings.get("compile_s", 0.0),
    }


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; exit code 0."""
    from ..surrogates.data import load_training_data
    from ..surrogates.fit import fit_surrogates
    from ..surrogates.report import format_report

    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    with tempfile.TemporaryDirectory() as tmp:
        root, source = _dataset(args, Path(tmp))
        data = load_training_data(root, OUTPUTS)
        start = time.perf_counter()
        classifiers = [k.strip() for k in args.classifiers.split(",") if k.strip()]
        surrogates = fit_surrogates(
            data,
            kinds=kinds,
            classifier_kind=classifiers,
            params=args.params,
            progress=lambda line: (
                print(f"bench surrogate: {line}", flush=True) if not args.json else None
            ),
        )
        wall = time.perf_counter() - start
        if args.save:
            from ..surrogates.report import report_figures
            from ..surrogates.store import save_surrogates

            # the bench refreshes its own record
            save_surrogates(
                surrogates, SAVED_MODEL, force=True, figures=report_figures(surrogates.report)
            )
    report = surrogates.report
    reset = reset_model_section(args.reset_designs)
    record = {
        "benchmark": "surrogate",
        "machine": machine_info(),
        "dataset": source,
        "fit_and_report_s": wall,
        "surrogates": report,
        "reset_model": reset["reset_model"],
    }
    text = format_report(report)
    text += "\n\nreset_model: " + json.dumps(reset["reset_model"])
    m = record["machine"]
    text += (
        f"\n\nmachine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, "
        f"NumPy {m['numpy']}, Numba {m['numba']}; fit and report {wall:.0f} s"
    )
    save = REPORTS / "bench-surrogate.json" if args.save else None
    if save is not None and (SAVED_MODEL / "speed_error.png").is_file():
        save.parent.mkdir(parents=True, exist_ok=True)
        (REPORTS / "bench-surrogate.png").write_bytes(
            (SAVED_MODEL / "speed_error.png").read_bytes()
        )
    emit(_json_ready(record), as_json=args.json, text=text, save=save)
    return 0


def _json_ready(record: dict[str, Any]) -> dict[str, Any]:
    from ..surrogates.store import json_safe

    return json_safe(record)
