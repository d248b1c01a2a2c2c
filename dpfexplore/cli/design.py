"""``dpfexplore design SCENE.toml [--out DIR] [--json] [--plot]``: inverse design of a scene.

Solves every target of a scene file (format in :mod:`dpfexplore.inverse.scene_file` and each
kind's ``spec`` module), verifies
each reported design by the exact model, prints a summary (or ``--json``) and writes the report
to ``DIR`` (default ``results/<scene name>``): ``summary.json``, ``history.parquet``, one design
TOML per target (``dpfexplore states`` reads it back) and, with ``--plot``, figures.

``--target-reset T`` replaces a pick-and-place scene's targets with the one reset time ``T``.
A constants set whose file records that it failed validation against printed fingers
(``dpfexplore validate --record``) is refused unless ``--allow-unvalidated``.

Exit codes: 0 every target met, 1 some target unreachable or a check failed (the report says
which, and why), 2 bad input (one line on stderr; nothing written).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.progress import Progress
from . import EXIT_FAILURE, EXIT_OK, UsageError
from .support.inputs import add_constants_option, refuse_failed_set
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
    parser.add_argument(
        "--allow-unvalidated",
        action="store_true",
        help="design on a constants set whose file records that it failed validation against "
        "printed fingers (dpfexplore validate); refused otherwise",
    )
    parser.set_defaults(handler=run)


class _TargetProgress:
    """The targets as a stage of the display, each result a line, each evaluation batch a detail."""

    def __init__(self, display: Progress) -> None:
        self.display = display

    def start(self, total: int) -> None:
        self.display.stage("targets", total, unit="target")

    def batch(self, text: str) -> None:
        self.display.update(detail=text)

    def advance(self, text: str) -> None:
        self.display.note(text)
        self.display.update(advance=1, detail="")

    def stage(self, text: str) -> None:
        self.display.stage(text)

    def close(self) -> None:
        self.display.end_stage()


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore design``."""
    from ..inverse.design import run_design
    from ..inverse.kinds import SCENE_KINDS, SCENE_OPTIONS, load_scene
    from ..inverse.scene_file import SceneSpecError
    from ..io.result_dirs import ResultError, check_output_dir

    try:
        spec = load_scene(args.scene)
        for name, apply in SCENE_OPTIONS.items():
            if getattr(args, name) is not None:
                spec = apply(spec, getattr(args, name))
    except (SceneSpecError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    refuse_failed_set(spec.constants, args.allow_unvalidated)
    out = args.out if args.out is not None else Path("results") / spec.name
    try:  # before the solve: refusing after minutes of work helps nobody
        check_output_dir(out, force=args.force)
    except ResultError as exc:
        raise UsageError(str(exc)) from None
    try:
        with Progress("design") as display:
            outcome = run_design(
                spec, out, plot=args.plot, progress=_TargetProgress(display), force=args.force
            )
    except ResultError as exc:  # another writer took the directory meanwhile
        raise UsageError(str(exc)) from None
    rows = outcome.rows
    if args.json:
        document = {
            "results": rows,
            "evaluations": dict(outcome.evaluator.counts),
            "wall_s": outcome.wall_s,
        }
        print(json_text(document, indent=None))
    else:
        kind = SCENE_KINDS[spec.kind]
        counts = ", ".join(f"{k} {v}" for k, v in outcome.evaluator.counts.items() if v)
        print(f"design {spec.name} ({spec.kind}): {len(rows)} result(s) in {out}")
        for line in kind.summary(spec, rows):
            print(line)
        print(
            f"  every reported design {kind.verified}; evaluations: {counts}; "
            f"wall {outcome.wall_s:.2f} s"
        )
    return EXIT_OK if all(r.met for r in outcome.results) else EXIT_FAILURE
