"""``dpfexplore reset-model fit|report|upgrade``: train, inspect and upgrade fast reset models."""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

from ..io.progress import Progress
from . import EXIT_OK, UsageError
from .support.output import announce_compilation, json_text, output_path


def register(subparsers) -> None:
    """Add ``reset-model`` and its ``fit``, ``report`` and ``upgrade`` subcommands."""
    parser = subparsers.add_parser(
        "reset-model",
        help="train (fit) or describe (report) the fast reset-time model",
        description="The fast reset-time model (reset_times_batch(..., method='fast')): a "
        "physical core with a fitted correction, a 90 % interval and a fallback. 'fit' trains "
        "one by active learning on designs simulated by the full model; 'report' describes one; "
        "'upgrade' rewrites a model file of an earlier format in this one, checked, with the "
        "same numbers.",
    )
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    fit = sub.add_parser(
        "fit",
        help="train a model and write it as JSON",
        description="Train the fitted part of the fast reset-time model.",
    )
    fit.add_argument("--out", type=Path, required=True, help="model file to write (.json)")
    fit.add_argument("--P0", type=float, default=0.7, help="pulse pressure, MPa")
    fit.add_argument("--tau", default="0,1,5,5.1", help="tau1,tau2,tau3,tau4 in s")
    fit.add_argument(
        "--horizon",
        type=float,
        default=15.0,
        help="longest horizon t_end - tau4 the model serves, s",
    )
    fit.add_argument("--initial", type=int, default=3000, help="uniform designs first")
    fit.add_argument(
        "--per-round", type=int, default=1000, help="actively chosen designs per round"
    )
    fit.add_argument("--rounds", type=int, default=2, help="active-learning rounds")
    fit.add_argument("--pool", type=int, default=8000, help="candidates scored per round")
    fit.add_argument(
        "--calibration",
        type=int,
        default=2000,
        help="uniform designs for the conformal calibration",
    )
    fit.add_argument(
        "--test-designs",
        type=int,
        default=500,
        help="held-out bench designs evaluated into the model's record (0: skip)",
    )
    fit.add_argument("--atol", type=float, default=3e-3, help="the core's tolerance, mm")
    fit.add_argument("--seed", type=int, default=2025, help="seed of the training designs")
    fit.add_argument("--json", action="store_true", help="print the training record as JSON")
    fit.set_defaults(handler=run_fit)
    report = sub.add_parser(
        "report",
        help="describe a model (default: the packaged one)",
        description="Print a model's scene, domain, training and test "
        "record and which features its correction uses.",
    )
    report.add_argument("model", nargs="?", default=None, help="model file (.json)")
    report.add_argument("--json", action="store_true", help="print the model's record as JSON")
    report.set_defaults(handler=run_report)
    upgrade = sub.add_parser(
        "upgrade",
        help="rewrite a format-1 model file (no checksum) in this format, numbers kept",
        description="Check every tree and value of a model file of format version 1 and write "
        "it in this version's format (checksum, provenance, recorded output ranges); every "
        "number is kept, so its reset times stay bit for bit.",
    )
    upgrade.add_argument("model", type=Path, help="model file of format version 1 (.json)")
    upgrade.add_argument("--out", type=Path, required=True, help="model file to write (.json)")
    upgrade.set_defaults(handler=run_upgrade)


def _tau(text: str) -> tuple[float, float, float, float]:
    try:
        tau = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise UsageError(f"--tau {text!r}: give four comma-separated times in s") from None
    if len(tau) != 4:
        raise UsageError(f"--tau {text!r}: give four comma-separated times in s")
    return tau  # type: ignore[return-value]


def run_fit(args) -> int:
    """Handler of ``reset-model fit``."""
    from ..model.pressure import PressureProfile
    from ..surrogates.reset_training import TrainingOptions, fit_reset_model

    counts = {
        "--initial": args.initial,
        "--per-round": args.per_round,
        "--rounds": args.rounds,
        "--pool": args.pool,
        "--calibration": args.calibration,
        "--test-designs": args.test_designs,
    }
    for flag, value in counts.items():
        if value < (1 if flag in ("--initial", "--calibration") else 0):
            raise UsageError(f"{flag} {value}: must be a positive count")
    for flag, value in (("--P0", args.P0), ("--horizon", args.horizon), ("--atol", args.atol)):
        if not (math.isfinite(value) and value > 0.0):
            raise UsageError(f"{flag} {value}: must be a finite number > 0")
    if args.out.suffix != ".json":
        raise UsageError(f"--out {args.out}: the model is written as JSON; name it *.json")
    tau = _tau(args.tau)
    if not all(math.isfinite(v) for v in tau):
        raise UsageError(f"--tau {args.tau!r}: the four times must be finite numbers, s")
    if any(b < a for a, b in pairwise(tau)) or tau[0] < 0:
        raise UsageError(f"--tau {args.tau!r}: need 0 <= tau1 <= tau2 <= tau3 <= tau4")
    try:  # the pulse's own checks (pressure range), before minutes of training
        PressureProfile.pulse(args.P0, tau)
    except ValueError as exc:
        raise UsageError(f"--P0 {args.P0:g} --tau {args.tau}: {exc}") from None
    output_path(args.out, "--out")  # a folder that cannot be made fails now, not after the training
    options = TrainingOptions(
        P0=args.P0,
        tau=tau,
        horizon=args.horizon,
        initial=args.initial,
        per_round=args.per_round,
        rounds=args.rounds,
        pool=args.pool,
        calibration=args.calibration,
        atol=args.atol,
        seed=args.seed,
    )
    with Progress("reset-model fit") as display:
        announce_compilation("reset-model", ["reset"])
        display.stage("fitting")
        model, record = fit_reset_model(options, progress=display.note)
    if args.test_designs and (args.P0, tau) == (0.7, (0.0, 1.0, 5.0, 5.1)):
        from ..bench.reset_model import reset_model_record

        test = reset_model_record(args.test_designs, model=model)
        model.info["test"] = {k: v for k, v in test.items() if k != "goals_met"}
    try:
        path = model.save(args.out)
    except OSError as exc:
        raise UsageError(f"--out {args.out}: cannot write ({exc.strerror or exc})") from None
    record = {**record, "test": model.info.get("test"), "saved": str(path)}
    if args.json:
        print(json_text(record))
    else:
        print(_summary(model, path))
    return EXIT_OK


def run_report(args) -> int:
    """Handler of ``reset-model report``."""
    from ..solvers.dynamics.reset_model import DEFAULT_MODEL_PATH, load_reset_model

    path = Path(args.model) if args.model else DEFAULT_MODEL_PATH
    try:
        model = load_reset_model(path)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.json:
        data = {k: v for k, v in model.to_dict().items() if k not in ("correction", "scale")}
        print(json_text(data))
    else:
        print(_summary(model, path))
    return EXIT_OK


def run_upgrade(args) -> int:
    """Handler of ``reset-model upgrade``."""
    from ..solvers.dynamics.reset_model import upgrade_reset_model

    if args.out.suffix != ".json":
        raise UsageError(f"--out {args.out}: the model is written as JSON; name it *.json")
    try:
        model = upgrade_reset_model(args.model)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    try:
        path = model.save(output_path(args.out, "--out"))
    except OSError as exc:
        raise UsageError(f"--out {args.out}: cannot write ({exc.strerror or exc})") from None
    print(f"reset model {args.model} upgraded to format version 2: {path}")
    return EXIT_OK


def _summary(model, path) -> str:
    info = model.info
    lines = [
        f"reset model {path}",
        f"scene: P0 = {model.P0} MPa, tau = {list(model.tau)} s, horizons up to "
        f"{model.horizon_max} s",
        "domain: "
        + ", ".join(f"{k} {tuple(v)}" for k, v in model.domain.items() if k != "fixed")
        + "; fixed "
        + ", ".join(f"{k} = {v}" for k, v in model.domain["fixed"].items()),
        f"core tolerance {model.atol} mm; interval: {model.coverage:.0%} conformal, q = "
        f"{model.conformal_q:.3f}, monostable ± {model.abs_halfwidth * 1e3:.2f} ms; falls back "
        f"below a snap margin of {model.margin_min:.3g} N",
        f"trees: correction {model.correction.roots.size}, scale {model.scale.roots.size}",
    ]
    if info:
        opts = info.get("options", {})
        lines.append(
            f"trained {info.get('trained')} in {info.get('seconds')} s: {opts.get('initial')} "
            f"uniform + {opts.get('rounds')} x {opts.get('per_round')} actively chosen designs "
            f"(pools of {opts.get('pool')}), {opts.get('calibration')} calibration designs; "
            f"labels rodas4 atol {info.get('reference_atol_mm')} mm"
        )
        top = list(info.get("feature_importance", {}).items())[:6]
        lines.append(
            "correction's main features (mean |change| when permuted, log units): "
            + ", ".join(f"{k} {v:.1e}" for k, v in top)
        )
        test = info.get("test")
        if test:
            lines.append(
                f"held-out test ({test['designs']} bench designs, seed {test['seed']}): median "
                f"{test['median_rel_err']:.2e}, p95 {test['p95_rel_err']:.2e}, max "
                f"{test['max_rel_err']:.2e} relative; class agreement "
                f"{test['class_agreement']:.3%}; coverage {test['coverage_90']:.1%}; fallback "
                f"{test['fallback_rate']:.1%}; {test['us_per_design']:.0f} µs per design "
                f"(full model {test['full_model_us_per_design']:.0f} µs, same run)"
            )
    return "\n".join(lines)
