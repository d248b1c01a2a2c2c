"""Text form of a surrogate report (held-out errors, classifier, speed, goals, verdict)."""

from __future__ import annotations

from typing import Any

from .store import SPEED_PNG

__all__ = ["format_report"]


def _table(rows: list[dict[str, Any]], columns: list[tuple[str, str, str]]) -> str:
    header = " ".join(
        f"{title:>{len(title) if i == 0 else 10}}" for i, (title, _, _) in enumerate(columns)
    )
    lines = [header]
    for row in rows:
        cells = []
        for i, (title, key, fmt) in enumerate(columns):
            value = row.get(key)
            text = "" if value is None else (format(value, fmt) if fmt else str(value))
            cells.append(f"{text:>{len(title) if i == 0 else 10}}")
        lines.append(" ".join(cells))
    return "\n".join(lines)


def format_report(report: dict[str, Any]) -> str:
    """The report as text: errors of the headline output per N, classifier, speed, verdict."""
    headline = report["headline"]
    unit = "mm" if headline == "tip" else report["units"].get(headline, "")
    split = report["split"]
    lines = [
        f"dataset {report['dataset']['path']}: {split['train_designs']} training designs, "
        f"{split['test_designs']} held out (split by design_id, seed {split['seed']}); "
        f"{'one model per N' if report['per_n'] else 'N as a feature'}",
        "",
        f"held-out {headline} error ({unit}), by model and N:",
    ]
    errors = [r for r in report["errors"] if r["output"] == headline]
    lines.append(
        _table(
            errors,
            [
                ("model     ", "model", ""),
                ("N", "n_units", ""),
                ("designs", "n", "d"),
                ("median", "median", ".4g"),
                ("p95", "p95", ".4g"),
                ("max", "max", ".4g"),
            ],
        )
    )
    others = [r for r in report["errors"] if r["output"] != headline and r["n_units"] == "all"]
    if others:
        lines += ["", "held-out error of every output, all N (relative to |true value|):"]
        lines.append(
            _table(
                others,
                [
                    ("model     ", "model", ""),
                    ("output", "output", ""),
                    ("median", "median", ".4g"),
                    ("p95", "p95", ".4g"),
                    ("max", "max", ".4g"),
                    ("median rel", "median_rel", ".3g"),
                    ("p95 rel", "p95_rel", ".3g"),
                ],
            )
        )
    clf = report["classifier"]
    lines += [""]
    # Reports written before several classifiers were compared hold only the one.
    for record in report.get("classifiers", [clf]):
        per_n = ", ".join(f"N={n}: {a:.4f}" for n, a in record["accuracy_per_n"].items())
        used = " (used)" if record["kind"] == clf["kind"] else ""
        errors = (
            f"; {record['missed']} existing states called collapsed, "
            f"{record['false_alarms']} collapsed called existing"
            if "missed" in record
            else ""
        )
        lines.append(
            f"status classifier ({record['kind']}){used}: held-out accuracy "
            f"{record['accuracy']:.4f} ({per_n}){errors}"
        )
    lines.append(
        f"exact model agrees with the dataset's status on {clf['exact_model_agreement']:.4f}"
    )
    if report["speed"]:
        lines += ["", "speed on one core (µs per prediction) and held-out error:"]
        lines.append(
            _table(
                report["speed"],
                [
                    ("model                ", "model", ""),
                    ("batched", "us_batched", ".2f"),
                    ("single", "us_single", ".1f"),
                    (f"{headline} med", f"{headline}_median", ".4g"),
                    (f"{headline} p95", f"{headline}_p95", ".4g"),
                    ("fit s", "fit_s", ".1f"),
                ],
            )
        )
    lines += ["", "goals:"]
    for name, goal in report["goals"].items():
        value = f"{goal['value']:,}" if isinstance(goal["value"], int) else f"{goal['value']:.4g}"
        where = f" at N = {goal['n_units']}" if "n_units" in goal else ""
        lines.append(
            f"  {name}: {value}{where} (goal {goal['goal']:,}): "
            f"{'met' if goal['met'] else 'NOT met'}"
        )
    lines += ["", report["verdict"]]
    return "\n".join(lines)


def report_figures(report: dict[str, Any]) -> dict[str, Any]:
    """The figures saved beside a surrogate: its speed-error chart (``speed_error.png``).

    Returns a mapping of file name to matplotlib Figure (empty without speed measurements).
    """
    if not report.get("speed"):
        return {}
    import pandas as pd
    from matplotlib.figure import Figure

    from ..plotting.surrogates import plot_speed_error

    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    plot_speed_error(
        pd.DataFrame(report["speed"]), error=f"{report['headline']}_p95", ax=fig.subplots()
    )
    return {SPEED_PNG: fig}
