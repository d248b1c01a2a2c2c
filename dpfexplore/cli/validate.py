"""``dpfexplore validate [FILE ...] [--constants SET ...] [--json] [--plot FILE.png]``.

How well constants sets predict printed fingers (:func:`dpfexplore.measurements.validate`): by
default the packaged measurements (the paper's printed fingers) under the paper's set and every
packaged set. Prints a table per finger and set, per set and material, the verdicts against the
goal and a one-line summary (or ``--json``); ``--plot`` draws every finger, ``--report FILE.md``
writes the Markdown page the documentation includes, ``--record`` writes each set's verdict into
its file (:mod:`dpfexplore.measurements.verdict`).

Exit codes: 0 every set meets the goal (or no verdict was asked for: the paper's set not among
the sets), 1 some set fails it or a solve failed, 2 bad input (one line on stderr; nothing
computed).
"""

from __future__ import annotations

import argparse
import os
import shlex
from pathlib import Path

from . import EXIT_FAILURE, EXIT_OK, UsageError
from .support.inputs import CONSTANTS_HELP
from .support.output import (
    FIGURE_SUFFIXES,
    announce_compilation,
    json_text,
    output_path,
    save_figure,
)


def register(subparsers) -> None:
    """Add the ``validate`` subcommand."""
    parser = subparsers.add_parser(
        "validate",
        help="how well constants sets predict printed fingers (measured tips and stiffness)",
        description="Solve measured fingers under constants sets and compare with the "
        "measurements: predicted against measured tip (distance in mm, and relative to the "
        "measured tip's distance from the base), whether the measured state holds, predicted "
        "against measured tip stiffness; per set and material the mean, RMS and max distance "
        "and the fingers held; a verdict per set against the goal (every state held, mean "
        "distance per material at most 1.25x the paper set's, stiffness within 25 %). Every "
        "predicted value is re-solved by the exact model (find_state). Default: the paper's "
        "printed fingers (packaged) under the paper's set and every packaged set. Units: mm, "
        "N/mm, MPa; tips in the finger frame (base at the origin, finger along +x).",
    )
    parser.add_argument(
        "files",
        nargs="*",
        metavar="FILE",
        help="measurement files (TOML, [[finger]] tables; format: dpfexplore.measurements."
        "fingers); default: the packaged ones (the paper's printed fingers)",
    )
    parser.add_argument(
        "--constants",
        metavar="SET",
        nargs="+",
        action="extend",
        default=None,
        help=f"constants sets to validate, one or more ({CONSTANTS_HELP.split(';')[0]}); "
        "default: 'paper' and every packaged set (give measurement FILEs before it)",
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument(
        "--plot", metavar="FILE.png", help="draw every finger under every set to a figure"
    )
    parser.add_argument(
        "--report",
        metavar="FILE.md",
        help="also write the results as a Markdown page (the figure of --plot linked)",
    )
    parser.add_argument(
        "--record",
        action="store_true",
        help="write each set's verdict into its file (a set file or a packaged set; the "
        "packaged measurements only)",
    )
    parser.set_defaults(handler=run)


def _sets(args: argparse.Namespace) -> list:
    """The sets the command validates, each with the file it came from (None for 'paper')."""
    from ..model.constants_set import (
        DEFAULT,
        ConstantsSetError,
        load_constants_set,
        locate_constants_set,
        packaged_sets,
    )

    names = args.constants or [DEFAULT.name, *packaged_sets()]
    found = []
    for name in names:
        try:
            path = locate_constants_set(name)
            constants = DEFAULT if path is None else load_constants_set(path)
        except ConstantsSetError as exc:
            raise UsageError(f"--constants {exc}") from None
        found.append((constants, path))
    seen = [c.name for c, _ in found]
    for name in seen:
        if seen.count(name) > 1:
            raise UsageError(f"--constants: two sets are named {name!r}; give each set once")
    return found


def _command_line(args: argparse.Namespace) -> str:
    parts = ["dpfexplore", "validate", *args.files]
    if args.constants:
        parts += ["--constants", *args.constants]
    for option in ("plot", "report"):
        if getattr(args, option):
            parts += [f"--{option}", str(getattr(args, option))]
    return " ".join(shlex.quote(p) for p in parts)


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore validate``."""
    from ..io.files import atomic_write
    from ..measurements import MeasurementError, read_measurements, validate
    from ..measurements.report import markdown_report, text_report
    from ..model.constants_set import ConstantsSetError

    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    report = output_path(args.report, "--report", suffixes=(".md",)) if args.report else None
    if args.record and args.files:
        raise UsageError("--record: a verdict is on the packaged measurements; give no FILE")
    try:  # before the sets: reading a set marked failing announces it, bad input is one line
        files = [read_measurements(p) for p in args.files] or None
    except MeasurementError as exc:
        raise UsageError(str(exc)) from None
    sets = _sets(args)
    if args.record and not any(path is not None for _, path in sets):
        raise UsageError("--record: name a set file or a packaged set ('paper' is built in)")
    announce_compilation("validate", ["states"])
    validation = validate(files, [c for c, _ in sets])
    if args.record:
        from ..measurements.verdict import record_verdict

        for _, path in sets:
            if path is not None:
                try:
                    record_verdict(path)
                except ConstantsSetError as exc:
                    raise UsageError(str(exc)) from None
    if args.json:
        print(json_text(validation.to_dict()))
    else:
        print(text_report(validation))
        if args.record:
            recorded = [str(path) for _, path in sets if path is not None]
            print(f"verdicts recorded in {', '.join(recorded)}")
    if plot is not None:
        from ..plotting.validation import plot_validation

        save_figure(plot_validation(validation.fingers), plot, dpi=110)
    if report is not None:
        figure = None
        if plot is not None:  # the page links the figure relative to itself
            figure = Path(os.path.relpath(plot.resolve(), report.resolve().parent)).as_posix()
        text = markdown_report(validation, command=_command_line(args), figure=figure)
        atomic_write(report, text)
    failed = [v for v in validation.verdicts if not v.passes]
    broken = [r for r in validation.fingers if r.status not in ("ok", "collapsed")]
    return EXIT_FAILURE if failed or broken else EXIT_OK
