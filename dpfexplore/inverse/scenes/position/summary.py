"""The text summary of a position scene's results (``dpfexplore design`` without ``--json``).

One table row per target (its tip, objective, stiffness, evaluations, wall time), with the
stiffness front, the reference and a fitted-range warning under it when the row has them; the
position-and-stiffness scene prints the same.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ...report import fitted_range_warning
from ...report import text_number as _fmt
from ...spec import SceneSpec

__all__ = ["summary_lines"]


def summary_lines(spec: SceneSpec, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The summary's lines of the ``--json`` rows ``rows``."""
    lines = [
        f"{'target':>16}  {'N':>2}  {'tip x':>9}  {'tip y':>9}  {'objective':>10}  "
        f"{'stiffness':>9}  {'evals':>6}  {'wall':>6}  reached",
        f"{'mm':>16}  {'':>2}  {'mm':>9}  {'mm':>9}  {'mm²':>10}  {'N/mm':>9}  {'':>6}  {'s':>6}",
    ]
    for r in rows:
        target = f"({r['target'][0]:g}, {r['target'][1]:g})"
        lines.append(
            f"{target:>16}  {r['n_units']:>2}  {r['tip'][0]:9.4f}  {r['tip'][1]:9.4f}  "
            f"{_fmt(r['objective'], '10.3g')}  {_fmt(r['stiffness'], '9.5f')}  "
            f"{r['evaluations']['designs']:>6}  {r['wall_s']:6.2f}  "
            f"{'yes' if r['reachable'] else 'UNREACHABLE'}"
        )
        if "front" in r:
            ks = [p.get("stiffness") for p in r["front"]]
            # each rung whole on a line: "0.1: 0.1716" never split
            line = "      front (tol mm: N/mm):"
            for n, (p, k) in enumerate(zip(r["front"], ks, strict=True)):
                rung = f" {p['tolerance_mm']:g}: {_fmt(k, '.4f')}" + (
                    "," if n < len(ks) - 1 else ""
                )
                if len(line) + len(rung) > 96:
                    lines.append(line)
                    line = "       "
                line += rung
            lines.append(line)
            lines += _answer_lines(spec, r)
        if "reference" in r:
            ref, dom = r["reference"], r.get("dominates_reference")
            lines.append(
                f"      reference: objective {_fmt(ref['objective'], '.3g')} mm², "
                f"stiffness {_fmt(ref['stiffness'], '.4f')} N/mm; "
                + ("dominated" if dom else "NOT dominated")
            )
        lines += fitted_range_warning(r)
    return lines


def _answer_lines(spec: SceneSpec, row: Mapping[str, Any]) -> list[str]:
    """Which design answers a position-and-stiffness target, and why.

    The scene asks for the stiffest design whose tip meets the target (its ``objective.
    tolerance``, mm², is met within ``sqrt(tolerance)`` mm): the front's design at the loosest
    rung within that distance. The table row above is the design closest to the target, found
    by the position search before stiffness enters; it is the front's seed, not the answer.
    """
    within = math.sqrt(spec.kind_spec.tolerance) * (1.0 + 1e-9)
    index = [
        i
        for i, p in enumerate(row["front"])
        if p["tolerance_mm"] <= within and p.get("stiffness") is not None
    ]
    if not index:
        return [f"      answer: no design of the front within the scene's {within:.3g} mm"]
    i = index[-1]
    p = row["front"][i]
    return [
        f"      answer: N {p['n_units']}, {_fmt(p['stiffness'], '.4f')} N/mm, "
        f"{_fmt(p.get('distance_mm'), '.2g')} mm from the target: the stiffest design within the",
        f"        scene's tolerance ({within:.3g} mm; summary.json: front[{i}]); the row above is "
        "the closest",
    ]
