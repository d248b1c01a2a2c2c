"""``dpfexplore design SCENE.toml [--out DIR] [--json] [--plot]``: inverse design of a scene.

Solves every target of a scene file (format in :mod:`dpfexplore.inverse.scene_file`), verifies
each reported design by the exact model, prints a summary (or ``--json``) and writes the report
to ``DIR`` (default ``results/<scene name>``): ``summary.json``, ``history.parquet``, one design
TOML per target (``dpfexplore states`` reads it back) and, with ``--plot``, figures.

``--target-reset T`` replaces a pick-and-place scene's targets with the one reset time ``T``.

Exit codes: 0 every target met, 1 some target unreachable or a check failed (the report says
which, and why), 2 bad input (one line on stderr; nothing written).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import EXIT_FAILURE, EXIT_OK, UsageError
from .support.inputs import add_constants_option
from .support.output import json_text


def register(subparsers) -> None:
    """Add the ``design`` subcommand."""
    parser = subparsers.add_parser(
        "design",
        help="inverse design: designs that meet a scene's targets, verified",
        description="Find designs that meet the targets of a scene file (jobs/design-*.toml): "
        "tip positions, tip stiffness, gripper apertures. Every reported design is re-solved "
        "by the exact model. Units: mm, N/mm, MPa, degrees.",
    )
    parser.add_argument(
        "scene", type=Path, help="scene file (TOML), e.g. jobs/design-position-cheetah.toml"
    )
    parser.add_argument("--out", type=Path, help="report directory (default results/<name>)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--plot", action="store_true", help="also write figures (PNG) to --out")
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace --out when it holds an earlier result (never a sweep dataset)",
    )
    parser.add_argument(
        "--seeds",
        metavar="DATASET",
        default=None,
        help="position scenes: candidates from this sweep dataset's nearest tips "
        "(e.g. results/design-seeds-descending) instead of a Latin hypercube",
    )
    parser.add_argument(
        "--target-reset",
        type=float,
        default=None,
        metavar="T",
        help="pick-and-place scenes: one target reset time T (s) instead of the scene's targets",
    )
    add_constants_option(parser)
    parser.set_defaults(handler=run)


class _BarProgress:
    """tqdm bar over the targets on a terminal."""

    def __init__(self) -> None:
        self.bar = None

    def start(self, total: int) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total, unit="target", dynamic_ncols=True, file=sys.stderr)

    def advance(self, text: str) -> None:
        self.bar.set_postfix_str(text, refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class _LineProgress:
    """One line on stderr per target: for logs and pipes."""

    def start(self, total: int) -> None:
        self._emit(f"{total} target(s)")

    def advance(self, text: str) -> None:
        self._emit(text)

    def close(self) -> None:
        pass

    @staticmethod
    def _emit(text: str) -> None:
        print(f"{time.strftime('%H:%M:%S')} design: {text}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore design``."""
    from ..inverse.design import run_design
    from ..inverse.kinds import load_scene, with_constants_file
    from ..inverse.report import public
    from ..inverse.scene_file import with_seeds
    from ..inverse.scenes.timing_spec import with_target_reset
    from ..inverse.spec_fields import SceneSpecError
    from ..io.result_dirs import ResultError, check_output_dir

    try:
        spec = load_scene(args.scene)
        if args.constants is not None:
            spec = with_constants_file(spec, args.constants)
        if args.target_reset is not None:
            spec = with_target_reset(spec, args.target_reset)
        if args.seeds is not None:
            spec = with_seeds(spec, args.seeds)
    except (SceneSpecError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    out = args.out if args.out is not None else Path("results") / spec.name
    try:  # before the solve: refusing after minutes of work helps nobody
        check_output_dir(out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    progress = _BarProgress() if sys.stderr.isatty() else _LineProgress()
    try:
        outcome = run_design(spec, out, plot=args.plot, progress=progress, force=args.force)
    except ResultError as exc:  # another writer took the directory meanwhile
        raise UsageError(str(exc)) from None
    rows = [public(r) for r in outcome.rows]
    if args.json:
        document = {
            "results": rows,
            "evaluations": dict(outcome.evaluator.counts),
            "wall_s": outcome.wall_s,
        }
        print(json_text(document, indent=None))
    else:
        _print_summary(spec, rows, outcome, out)
    failed = [
        r
        for r in rows
        if not r["reachable"]
        or r.get("windows_ok") is False
        or (r.get("metastability") and not r["metastability"].get("ok", True))
    ]
    return EXIT_FAILURE if failed else EXIT_OK


def _fmt(value, spec: str) -> str:
    if value is None:
        return "nan"
    if isinstance(value, str):
        return value
    return format(value, spec)


def _print_summary(spec, rows, outcome, out: Path) -> None:
    counts = ", ".join(f"{k} {v}" for k, v in outcome.evaluator.counts.items() if v)
    print(f"design {spec.name} ({spec.kind}): {len(rows)} result(s) in {out}")
    if spec.kind in ("pickplace", "walker_leg"):
        from .support.timing_output import print_timing_summary

        print_timing_summary(spec, rows)
        print(
            f"  every reported design re-simulated alone in the full model; evaluations: "
            f"{counts}; wall {outcome.wall_s:.2f} s"
        )
        return
    if spec.kind == "gripper":
        for r in rows:
            ap = ", ".join(f"{a:.3f}" for a in r["apertures"])
            print(
                f"  apertures {ap} mm (targets {r['target']}), theta_B {r['theta_B_deg']:.3f}"
                f" deg, Base_L {r['base_L']:.3f} mm, stiffness {_fmt(r['stiffness'], '.5f')}"
                f" N/mm"
            )
            meta = r.get("metastability") or {}
            print(
                f"  tip unit: reset after {_fmt(meta.get('reset_time_s'), '.4f')} s "
                f"({'ok' if meta.get('ok') else 'NOT metastable'})"
            )
            windows = "; ".join(
                "-" if w is None else f"{w[0]:.1f}-{w[1]:.1f}"
                for w in r["pressure_windows_kPa"] or []
            )
            print(
                f"  pressure windows (kPa): {windows} "
                f"({'ok' if r.get('windows_ok') else 'NOT ok'}; "
                f"{r['pressure_windows_kPa_detail'].get('note')})"
            )
            if "reference" in r:
                ref = r["reference"]
                ap = ", ".join(f"{a:.3f}" for a in ref["apertures"])
                print(
                    f"  reference: apertures {ap} mm, stiffness "
                    f"{_fmt(ref['stiffness'], '.5f')} N/mm"
                )
            _print_range(r)
    else:
        print(
            f"{'target':>16}  {'N':>2}  {'tip x':>9}  {'tip y':>9}  {'objective':>10}  "
            f"{'stiffness':>9}  {'evals':>6}  {'wall':>6}  reached"
        )
        print(
            f"{'mm':>16}  {'':>2}  {'mm':>9}  {'mm':>9}  {'mm²':>10}  {'N/mm':>9}  "
            f"{'':>6}  {'s':>6}"
        )
        for r in rows:
            target = f"({r['target'][0]:g}, {r['target'][1]:g})"
            print(
                f"{target:>16}  {r['n_units']:>2}  {r['tip'][0]:9.4f}  {r['tip'][1]:9.4f}  "
                f"{_fmt(r['objective'], '10.3g')}  {_fmt(r['stiffness'], '9.5f')}  "
                f"{r['evaluations']['designs']:>6}  {r['wall_s']:6.2f}  "
                f"{'yes' if r['reachable'] else 'UNREACHABLE'}"
            )
            if "front" in r:
                ks = [p.get("stiffness") for p in r["front"]]
                print(
                    "      front (tol mm: N/mm): "
                    + ", ".join(
                        f"{p['tolerance_mm']:g}: {_fmt(k, '.4f')}"
                        for p, k in zip(r["front"], ks, strict=True)
                    )
                )
            if "reference" in r:
                ref, dom = r["reference"], r.get("dominates_reference")
                print(
                    f"      reference: objective {_fmt(ref['objective'], '.3g')} mm², "
                    f"stiffness {_fmt(ref['stiffness'], '.4f')} N/mm; "
                    + ("dominated" if dom else "NOT dominated")
                )
            _print_range(r)
    print(
        f"  every reported design re-solved by find_state; evaluations: {counts}; "
        f"wall {outcome.wall_s:.2f} s"
    )


def _print_range(row) -> None:
    if not row.get("fitted_range", True):
        print(f"      warning: {row['fitted_range_note']}")
