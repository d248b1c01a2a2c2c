"""``dpfexplore surrogate fit | report | predict``: surrogates of sweep outputs with their error.

* ``surrogate fit DATASET --outputs tip_x,tip_y,stiffness --out results/surrogates/NAME``
  holds out a share of the designs, fits each kind of surrogate and the status classifier on
  the rest, measures held-out error and speed against the exact model, and saves it all.
* ``surrogate report NAME`` prints the saved report (``NAME``: a directory, or a name under
  ``results/surrogates/``).
* ``surrogate predict NAME DESIGNS.parquet [--out FILE]`` predicts the outputs of design rows,
  with the probability that the requested state exists and the in-range flag: a row outside
  the box the surrogate was fitted on is flagged, never silently trusted.

Exit codes: 0 done, 2 bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from . import EXIT_OK, UsageError
from .support.inputs import add_constants_option, constants_argument, saved_path
from .support.output import json_text, save_table

#: Where ``surrogate report|predict NAME`` looks for a bare name.
SURROGATES = Path("results") / "surrogates"


def register(subparsers) -> None:
    """Add ``surrogate`` and its subcommands."""
    parser = subparsers.add_parser(
        "surrogate",
        help="fit, report and use surrogates of sweep outputs (with their held-out error)",
        description=__doc__.split("\n\n", 1)[1],
    )
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    fit = sub.add_parser("fit", help="fit surrogates of a sweep dataset and save them")
    fit.add_argument("dataset", type=Path, help="sweep dataset directory")
    fit.add_argument(
        "--outputs",
        required=True,
        help="comma-separated output columns, e.g. tip_x,tip_y,stiffness",
    )
    fit.add_argument(
        "--out",
        type=Path,
        required=True,
        help="directory to save into, e.g. results/surrogates/NAME",
    )
    fit.add_argument(
        "--force", action="store_true", help="replace --out when it holds an earlier result"
    )
    fit.add_argument(
        "--kinds",
        default="knn,gbt,mlp,gp,chain",
        help="regressor kinds to fit and compare (default knn,gbt,mlp,gp,chain)",
    )
    fit.add_argument(
        "--classifier",
        default="gbt,chain",
        help="status classifier kinds (gbt, mlp, chain), comma-separated; the "
        "most accurate held-out is used (default gbt,chain)",
    )
    fit.add_argument(
        "--n-as-feature",
        action="store_true",
        help="one model for all N with N as a feature (default: one per N)",
    )
    fit.add_argument(
        "--test-fraction",
        type=float,
        default=1 / 6,
        help="share of the designs held out (default 1/6)",
    )
    fit.add_argument(
        "--max-train-designs",
        type=int,
        default=100_000,
        help="cap on the training designs (default 100000)",
    )
    fit.add_argument("--seed", type=int, default=0, help="seed of the split and the estimators")
    fit.add_argument(
        "--params",
        type=json.loads,
        default=None,
        metavar="JSON",
        help='estimator keyword arguments per kind (JSON), e.g. \'{"mlp": {"max_iter": 50}}\'',
    )
    fit.add_argument("--no-timing", action="store_true", help="skip the speed measurement")
    add_constants_option(fit)
    fit.set_defaults(handler=_fit)

    report = sub.add_parser("report", help="print a saved surrogate's report")
    report.add_argument("name", help="directory, or a name under results/surrogates/")
    report.add_argument("--json", action="store_true", help="print the JSON report")
    report.set_defaults(handler=_report)

    predict = sub.add_parser("predict", help="predict outputs of designs with a saved surrogate")
    predict.add_argument("name", help="directory, or a name under results/surrogates/")
    predict.add_argument(
        "designs",
        type=Path,
        help="Parquet file (or sweep directory) of design rows in the sweep "
        "schema: n_units, H_k, U_L_k, U_sep_k, t, t_lim, E, nu, r_b, t_ch",
    )
    predict.add_argument("--kind", help="which regressor (default: the best held-out one)")
    predict.add_argument(
        "--out",
        type=Path,
        help="write the predictions to FILE (.parquet or .csv) instead of printing them",
    )
    predict.add_argument(
        "--dataset", type=Path, help="refuse the surrogate unless it was fitted on this dataset"
    )
    add_constants_option(predict)
    predict.set_defaults(handler=_predict)


def _fit(args: argparse.Namespace) -> int:
    from ..io.commits import StoreError
    from ..io.result_dirs import ResultError, check_output_dir
    from ..surrogates.data import load_training_data
    from ..surrogates.fit import fit_surrogates
    from ..surrogates.report import format_report, report_figures
    from ..surrogates.store import save_surrogates

    try:  # before the fit: refusing after minutes of work helps nobody
        check_output_dir(args.out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    outputs = [o.strip() for o in args.outputs.split(",") if o.strip()]
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    if args.params is not None and not isinstance(args.params, dict):
        raise UsageError("--params: need a JSON object of kind -> keyword arguments")
    try:
        data = load_training_data(
            args.dataset, outputs, constants=constants_argument(args.constants)
        )
        surrogates = fit_surrogates(
            data,
            kinds=kinds,
            per_n=not args.n_as_feature,
            classifier_kind=[k.strip() for k in args.classifier.split(",") if k.strip()],
            test_fraction=args.test_fraction,
            max_train_designs=args.max_train_designs,
            seed=args.seed,
            params=args.params,
            timing=not args.no_timing,
            # a bar on a terminal (surrogates.progress), one line per step otherwise
            progress=None if sys.stderr.isatty() else _fit_line,
        )
    except StoreError as exc:
        raise UsageError(str(exc)) from None
    except (ValueError, TypeError) as exc:
        raise UsageError(str(exc).splitlines()[0]) from None
    try:
        save_surrogates(
            surrogates, args.out, force=args.force, figures=report_figures(surrogates.report)
        )
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    print(format_report(surrogates.report))
    print(f"saved to {args.out}")
    return EXIT_OK


def _fit_line(line: str) -> None:
    """A fit's progress off a terminal: one line per step."""
    print(f"surrogate fit: {line}", file=sys.stderr, flush=True)


def _report(args: argparse.Namespace) -> int:
    from ..surrogates.report import format_report
    from ..surrogates.store import SurrogateLoadError, read_report

    try:
        report = read_report(saved_path(args.name, SURROGATES))
    except SurrogateLoadError as exc:
        raise UsageError(str(exc)) from None
    print(json_text(report, indent=1) if args.json else format_report(report))
    return EXIT_OK


def _read_designs(path: Path):
    import io

    import pandas as pd
    import pyarrow as pa

    from ..io.files import BoundedReadError, read_bounded
    from ..sweep.storage.store import StoreError, read_results

    if (path / "_manifest.json").is_file():
        try:
            return read_results(path)
        except StoreError as exc:
            raise UsageError(str(exc)) from None
    if not path.exists():
        raise UsageError(f"{path}: no such file")
    try:
        raw = read_bounded(path, "designs table")
    except BoundedReadError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        frame = pd.read_parquet(io.BytesIO(raw))
    except (OSError, ValueError, pa.ArrowException) as exc:  # a file that is not Parquet
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UsageError(f"{path}: not a Parquet file of designs ({message})") from None
    if "n_units" not in frame.columns:
        raise UsageError(f"{path}: no 'n_units' column (need design rows in the sweep schema)")
    return frame.reset_index(drop=True)


def _predict(args: argparse.Namespace) -> int:
    from ..surrogates.store import SurrogateLoadError, load_surrogates

    try:
        surrogates = load_surrogates(
            saved_path(args.name, SURROGATES),
            dataset=args.dataset,
            constants=constants_argument(args.constants),
        )
    except SurrogateLoadError as exc:
        raise UsageError(str(exc)) from None
    designs = _read_designs(args.designs)
    from threadpoolctl import threadpool_limits

    try:
        with threadpool_limits(limits=1):  # see fit_surrogates(threads=...)
            predicted = surrogates.predict(designs, kind=args.kind)
    except ValueError as exc:
        raise UsageError(str(exc).splitlines()[0]) from None
    keep = [c for c in ("design_id", "n_units", "requested") if c in designs.columns]
    table = designs[keep].join(predicted)
    table["flag"] = ["" if inside else "OUT OF RANGE" for inside in table["in_range"]]
    flagged = int((~table["in_range"]).sum())
    if args.out is not None:
        save_table(table, args.out)
        print(f"{len(table)} predictions written to {args.out}")
    else:
        print(table.to_string(index=False, float_format=lambda v: f"{v:.5g}"))
    if flagged:
        print(
            f"surrogate predict: {flagged} of {len(table)} designs lie outside the range the "
            "surrogate was fitted on (flag OUT OF RANGE): do not trust their predictions; "
            "solve them with the exact model",
            file=sys.stderr,
        )
    return EXIT_OK
