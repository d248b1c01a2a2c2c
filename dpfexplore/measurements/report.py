"""A validation as people read it: the text table, the one-line summary, the Markdown report.

:func:`text_report` is what ``dpfexplore validate`` prints; :func:`summary_line` its last line
(one clause per set); :func:`markdown_report` the page ``dpfexplore validate --report FILE.md``
writes, which the documentation includes (``results/reports/validation.md``). Nothing here
computes: every number comes from the :class:`~.results.Validation` it is given.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from .results import SetSummary, Validation

#: The folder that holds the package: packaged files are named from there on.
_PACKAGE_PARENT = Path(__file__).resolve().parents[2]

__all__ = [
    "finger_rows",
    "markdown_report",
    "shown_path",
    "summary_line",
    "summary_rows",
    "text_report",
]

#: Columns of the per-finger table: header, unit.
FINGER_COLUMNS = (
    ("finger", ""),
    ("material", ""),
    ("set", ""),
    ("state", ""),
    ("found", ""),
    ("holds", ""),
    ("tip x", "mm"),
    ("tip y", "mm"),
    ("measured x", "mm"),
    ("measured y", "mm"),
    ("distance", "mm"),
    ("relative", "%"),
    ("stiffness", "N/mm"),
    ("measured", "N/mm"),
    ("ratio", ""),
)
#: Columns of the per-set table: header, unit.
SUMMARY_COLUMNS = (
    ("set", ""),
    ("material", ""),
    ("held", ""),
    ("tips", ""),
    ("mean", "mm"),
    ("RMS", "mm"),
    ("max", "mm"),
    ("mean relative", "%"),
    ("paper's model", "mm"),
    ("stiffness ratios", ""),
    ("outside fit", ""),
)


def _f(value: float | None, spec: str) -> str:
    if value is None:
        return "-"
    return "nan" if math.isnan(value) else format(value, spec)


def finger_rows(validation: Validation) -> list[list[str]]:
    """The per-finger table's cells (columns :data:`FINGER_COLUMNS`)."""
    rows = []
    for r in validation.fingers:
        measured = r.measured_tip or (None, None)
        rows.append(
            [
                r.finger + ("" if r.in_fitted_range else " †"),
                r.material,
                r.constants,
                r.requested,
                r.found or "-",
                "yes" if r.holds else "no",
                _f(r.predicted_tip[0], ".2f"),
                _f(r.predicted_tip[1], ".2f"),
                _f(measured[0], ".2f"),
                _f(measured[1], ".2f"),
                _f(r.distance, ".2f"),
                _f(None if r.relative_distance is None else 100 * r.relative_distance, ".1f"),
                _f(r.predicted_stiffness, ".4f"),
                _f(r.measured_stiffness, ".2f"),
                _f(r.stiffness_ratio, ".3f"),
            ]
        )
    return rows


def _ratios(s: SetSummary) -> str:
    if not s.stiffness_ratios:
        return "-"
    return ", ".join(
        f"{r:.2f}" + ("" if held else "*")
        for r, held in zip(s.stiffness_ratios, s.stiffness_held, strict=True)
    )


def summary_rows(validation: Validation) -> list[list[str]]:
    """The per-set table's cells (columns :data:`SUMMARY_COLUMNS`)."""
    return [
        [
            s.constants,
            s.material,
            f"{s.held}/{s.fingers}",
            str(s.tips),
            _f(s.mean_distance if s.tips else None, ".2f"),
            _f(s.rms_distance if s.tips else None, ".2f"),
            _f(s.max_distance if s.tips else None, ".2f"),
            _f(100 * s.mean_relative_distance if s.tips else None, ".1f"),
            _f(s.reference_mean_distance, ".2f"),
            _ratios(s),
            str(s.outside_fitted_range),
        ]
        for s in validation.summaries
    ]


def _table(columns: Sequence[tuple[str, str]], rows: Sequence[Sequence[str]]) -> list[str]:
    """A plain-text table: text columns left-aligned, numbers right-aligned, units under."""
    heads = [h for h, _ in columns]
    units = [u for _, u in columns]
    widths = [
        max(len(x) for x in [h, u, *(r[i] for r in rows)]) for i, (h, u) in enumerate(columns)
    ]
    numeric = [bool(u) or h in ("tips", "ratio", "outside fit") for h, u in columns]

    def line(cells: Sequence[str]) -> str:
        return "  ".join(
            c.rjust(w) if n else c.ljust(w) for c, w, n in zip(cells, widths, numeric, strict=True)
        ).rstrip()

    return [line(heads), line(units), *(line(r) for r in rows)]


def shown_path(path: str) -> str:
    """A measurement file as outputs name it: a packaged one from the package's folder on."""
    if not path:
        return "(given in Python)"
    try:
        return Path(path).resolve().relative_to(_PACKAGE_PARENT).as_posix()
    except ValueError:
        return path


def _sources(validation: Validation) -> str:
    return ", ".join(f"{shown_path(p)} (sha256 {h[:12]})" for p, _, h in validation.measurements)


def summary_line(validation: Validation) -> str:
    """One line: per set its mean tip distance per material, states held, stiffness ratios."""
    clauses = []
    for name, _ in validation.sets:
        mine = [s for s in validation.summaries if s.constants == name]
        distances = ", ".join(f"{s.mean_distance:.2f} mm {s.material}" for s in mine if s.tips)
        held = sum(s.held for s in mine)
        total = sum(s.fingers for s in mine)
        errors = [abs(r - 1) for s in mine for r in s.stiffness_ratios]
        text = f"{name!r}: mean tip distance {distances or '-'}; held {held}/{total}"
        if errors:  # a bound: rounded up
            text += f"; stiffness within {math.ceil(100 * max(errors) - 1e-9):d}%"
        try:
            text += "" if validation.verdict(name).passes else " (FAILS the goal)"
        except KeyError:
            pass
        clauses.append(text)
    return "validate: " + " | ".join(clauses)


def text_report(validation: Validation) -> str:
    """The table ``dpfexplore validate`` prints, ending with :func:`summary_line`."""
    n_sets = len(validation.sets)
    lines = [
        f"validate: {len({r.finger for r in validation.fingers})} fingers of "
        f"{_sources(validation)} under {n_sets} constants set{'s' if n_sets > 1 else ''}",
        f"  {validation.verified_by}",
        "",
        *_table(FINGER_COLUMNS, finger_rows(validation)),
    ]
    if any(not r.in_fitted_range for r in validation.fingers):
        lines.append("† outside the domain the set was fitted on (extrapolated constants):")
        seen = set()
        for r in validation.fingers:
            if not r.in_fitted_range and (r.constants, r.note) not in seen:
                seen.add((r.constants, r.note))
                lines.append(f"  {r.constants}: {r.note}")
    lines += ["", "per set and material (tip distances to the measured tips):"]
    lines += _table(SUMMARY_COLUMNS, summary_rows(validation))
    lines.append("stiffness ratios: predicted / measured; *: the measured state does not hold")
    if validation.verdicts:
        goal = validation.verdicts[0].goal
        lines += [
            "",
            f"verdicts (goal: every measured state held; mean tip distance per material at most "
            f"{goal.distance_factor:g}x the paper set's; every stiffness within "
            f"{goal.stiffness_tolerance:.0%}):",
        ]
        lines += [f"  {v.summary}" for v in validation.verdicts]
    lines += ["", summary_line(validation)]
    return "\n".join(lines)


def _markdown_table(columns: Sequence[tuple[str, str]], rows: Sequence[Sequence[str]]) -> list[str]:
    heads = [f"{h} ({u})" if u else h for h, u in columns]
    out = ["| " + " | ".join(heads) + " |", "|" + "|".join("---" for _ in heads) + "|"]
    out += ["| " + " | ".join(c.replace("|", "\\|") for c in r) + " |" for r in rows]
    return out


def markdown_report(validation: Validation, *, command: str, figure: str | None = None) -> str:
    """The Markdown page of a validation (``dpfexplore validate --report FILE.md``).

    Parameters
    ----------
    validation : Validation
    command : str
        The command line that produced it (shown, so that the page can be made again).
    figure : str, optional
        The figure's file name, relative to the page.
    """
    lines = [
        "# Validation against printed fingers",
        "",
        "Produced by the CLI, from the repository root (do not edit by hand):",
        "",
        "```bash",
        command,
        "```",
        "",
        f"Fingers: {_sources(validation)}. {validation.verified_by[0].upper()}"
        f"{validation.verified_by[1:]}. Units: mm, N/mm; relative distance = tip distance over "
        "the measured tip's distance from the base; the tips in the finger frame of MODEL.md §5.",
        "",
        f"**{summary_line(validation)}**",
        "",
    ]
    if figure:
        lines += [
            f"![Each printed finger under each constants set, the measured tip marked]({figure})",
            "",
        ]
    lines += [
        "## Per set and material",
        "",
        *_markdown_table(SUMMARY_COLUMNS, summary_rows(validation)),
    ]
    lines += [
        "",
        "Stiffness ratios: predicted / measured; *: the measured state does not hold.",
        "",
    ]
    if validation.verdicts:
        goal = validation.verdicts[0].goal
        lines += [
            "## Verdicts",
            "",
            f"The goal: every measured state held; the mean tip distance per material at most "
            f"{goal.distance_factor:g}x the paper set's; every measured stiffness within "
            f"{goal.stiffness_tolerance:.0%}.",
            "",
            *(f"- {v.summary}" for v in validation.verdicts),
            "",
        ]
    lines += ["## Per finger", "", *_markdown_table(FINGER_COLUMNS, finger_rows(validation))]
    notes = sorted({(r.constants, r.note) for r in validation.fingers if not r.in_fitted_range})
    if notes:
        lines += ["", "†: outside the domain the set was fitted on (extrapolated constants):", ""]
        lines += [f"- {name}: {note}" for name, note in notes]
    return "\n".join(lines) + "\n"
