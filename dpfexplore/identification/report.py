"""Saving an identification as a result directory, reading it back, and comparing sets.

A saved identification ``results/constants/NAME/`` holds ``constants.json`` (the constants set:
what the model reads), ``fits.csv`` (one row per curve: the fitted ``k_b``, ``alpha``, ``d``,
their uncertainties, the relative RMS residual and any flags), ``report.json`` (per closed form:
the grouped cross-validation curve, the terms chosen, the held-out scores of both selectors and
the winner) and, on request, ``selection.png``. It is written whole or not at all
(:func:`~dpfexplore.io.result_dirs.result_directory`) and verified before it is read.
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..io.files import SIZE_LIMITS, BoundedReadError, read_json_bounded
from ..model.constants import ALPHA_BISTABLE, ALPHA_GHOST
from ..model.constants_set import ConstantsSet, load_constants_set
from ..model.formatting import json_text
from ..model.quantities import SET_FORMS
from .identify import Identification

__all__ = [
    "CONSTANTS_FILE",
    "compare_sets",
    "format_report",
    "read_identification",
    "save_identification",
]

CONSTANTS_FILE = "constants.json"
FITS_FILE = "fits.csv"
REPORT_FILE = "report.json"
#: Largest report read, bytes (the reason in :data:`dpfexplore.io.files.SIZE_LIMITS`).
MAX_REPORT_BYTES = SIZE_LIMITS["identification report"].bytes
FIGURE_FILE = "selection.png"


def _report(result: Identification) -> dict[str, Any]:
    constants = result.constants
    return {
        "name": constants.name,
        "fingerprint": constants.fingerprint,
        "domain": {k: list(v) for k, v in constants.domain.items()},
        "curves": len(result.fits),
        "curves_flagged": sum(not f.ok for f in result.fits),
        "alpha_spread_over_E": result.alpha_spread_over_E,
        "notes": result.notes,
        "closed_forms": {
            target: {
                "text": selection.form.text(target),
                "selector": selection.selector,
                "n_terms": selection.n_terms,
                "cv_curve": selection.cv_curve,
                "heldout": selection.heldout,
            }
            for target, selection in result.selections.items()
        },
    }


def save_identification(
    result: Identification, path: str | Path, *, plot: bool = False, force: bool = False
) -> Path:
    """Write ``result`` as the result directory ``path`` (module docstring)."""
    from ..io.result_dirs import result_directory

    final = Path(path)
    facts = {"name": result.constants.name, "fingerprint": result.constants.fingerprint}
    with result_directory(final, kind="constants", force=force, description=facts) as staging:
        result.constants.save(staging / CONSTANTS_FILE)
        pd.DataFrame(
            [
                {
                    "curve": f.curve,
                    "k_b": f.k_b,
                    "alpha": f.alpha,
                    "d": f.d,
                    "k_b_std": f.std.get("k_b"),
                    "alpha_std": f.std.get("alpha"),
                    "d_std": f.std.get("d"),
                    "correlation_alpha_d": f.correlation_alpha_d,
                    "relative_rms": f.relative_rms,
                    "flags": "; ".join(f.flags),
                }
                for f in result.fits
            ]
        ).to_csv(staging / FITS_FILE, index=False)
        (staging / REPORT_FILE).write_text(json_text(_report(result)) + "\n")
        if plot:
            _figure(result).savefig(staging / FIGURE_FILE, dpi=130)
    return final


def _figure(result: Identification):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.2), layout="constrained")
    axes = fig.subplots(1, len(result.selections))
    for ax, (target, selection) in zip(np.atleast_1d(axes), result.selections.items(), strict=True):
        if selection.cv_curve:
            n = [p["n_terms"] for p in selection.cv_curve]
            rmse = [p["rmse"] for p in selection.cv_curve]
            std = [p["std"] for p in selection.cv_curve]
            ax.errorbar(n, rmse, yerr=std, marker="o", ms=3, capsize=2, label="grouped CV")
            ax.axvline(selection.n_terms, color="k", ls=":", label=f"1-SE: {selection.n_terms}")
            ax.set_yscale("log")
            ax.legend(fontsize=7)
        ax.set_title(target)
        ax.set_xlabel("terms (besides the constant)")
        ax.set_ylabel("RMSE on held-out geometries")
    return fig


def read_identification(path: str | Path) -> tuple[ConstantsSet, dict[str, Any]]:
    """The constants set and report of a saved identification, verified against its manifest.

    Raises
    ------
    ValueError
        One line: not a saved identification, a changed file, or an invalid set.
    """
    from ..io.result_dirs import verify_result_dir

    path = Path(path)
    verify_result_dir(path)
    constants = load_constants_set(path / CONSTANTS_FILE)
    try:
        report = read_json_bounded(path / REPORT_FILE, MAX_REPORT_BYTES)
    except BoundedReadError as exc:
        raise ValueError(str(exc)) from None
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path / REPORT_FILE}: unreadable ({exc})") from None
    if not isinstance(report, dict):
        raise ValueError(f"{path / REPORT_FILE}: not a report (a JSON object)")
    return constants, report


def format_report(report: dict[str, Any]) -> str:
    """The report as text: the closed forms written out, held-out scores, domain."""
    domain = report["domain"]
    lines = [
        f"constants set {report['name']} (fingerprint {report['fingerprint'][:12]})",
        f"  from {report['curves']} curves ({report['curves_flagged']} flagged); alpha varies "
        f"by {100 * report['alpha_spread_over_E']:.2g} % across E at one geometry",
        "  domain: " + ", ".join(f"{k} {lo:g}-{hi:g}" for k, (lo, hi) in domain.items()),
    ]
    for target, form in report["closed_forms"].items():
        n = _form_terms(form["text"])
        lines.append(
            f"  {target}: {_terms(n)} plus a constant, selected by {form['selector']} on all "
            "the curves:"
        )
        lines += _wrapped_form(form["text"])
        heldout = form.get("heldout") or {}
        if heldout:
            geometries = heldout.get("geometries", {})
            test = geometries.get("test", "?")
            train = geometries.get("train", "?")
            total = geometries.get("test", 0) + geometries.get("train", 0)
            # a stored count includes the constant (the refit's intercept)
            lines.append(
                f"    held-out geometries ({test} of {total}; each selector re-run on the other "
                f"{train}):"
            )
            for name in ("rfecv", "lasso"):
                if name in heldout:
                    lines.append(
                        f"      {name}: {_terms(heldout[name]['terms'] - 1)} + constant, RMSE "
                        f"{heldout[name]['rmse']:.3g}"
                        + (" (the better)" if heldout["winner"] == name else "")
                    )
    for note in report.get("notes", []):
        lines += textwrap.wrap(
            note, 96, initial_indent="  note: ", subsequent_indent="    ", break_on_hyphens=False
        )
    return "\n".join(lines)


def _wrapped_form(text: str, width: int = 96) -> list[str]:
    """A closed form's text in lines of at most ``width`` characters, each term kept whole."""
    name, _, rhs = text.partition(" = ")
    terms = re.findall(r"[+-]\S+(?: \S*π\S*)?", rhs)
    lines, line = [], f"    {name} ="
    for term in terms:
        if len(line) + 1 + len(term) > width and line.strip():
            lines.append(line)
            line = "       "
        line += f" {term}"
    return [*lines, line]


def _terms(n: int) -> str:
    return f"{n} term" if n == 1 else f"{n} terms"


def _form_terms(text: str) -> int:
    """Terms of a closed form's text besides its constant (``"k_hat = +4 -35.5 π1·π3 ..."``)."""
    return sum("π" in term for term in text.partition("=")[2].split())


def _unit_class(alpha: float) -> str:
    if alpha < ALPHA_BISTABLE:
        return "bistable"
    return "metastable" if alpha < ALPHA_GHOST else "monostable"


def compare_sets(
    sets: Sequence[ConstantsSet], H: Sequence[float], t: float, r_b: float, E: float
) -> pd.DataFrame:
    """One row per dome height: ``k_b``, ``alpha``, ``tip_dis`` and the class under each set.

    The quantities are those of :data:`~dpfexplore.model.quantities.SET_FORMS`, in its order.
    """
    rows = []
    for h in H:
        row: dict[str, Any] = {"H": h, "t": t}
        for constants in sets:
            values = constants.evaluate(h, t, r_b, E)
            prefix = constants.name
            for form in SET_FORMS:
                row[f"{prefix}:{form.quantity}"] = float(values[form.quantity])
            row[f"{prefix}:class"] = _unit_class(float(values["alpha"]))
            row[f"{prefix}:in_domain"] = bool(constants.in_domain(h, t, r_b, E))
        rows.append(row)
    return pd.DataFrame(rows)
