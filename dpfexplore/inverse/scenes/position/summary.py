"""The text summary of a position scene's results (``dpfexplore design`` without ``--json``).

One table row per target (its tip, objective, stiffness, evaluations, wall time), with the
stiffness front, the reference and a fitted-range warning under it when the row has them; the
position-and-stiffness scene prints the same.
"""

from __future__ import annotations

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
            lines.append(
                "      front (tol mm: N/mm): "
                + ", ".join(
                    f"{p['tolerance_mm']:g}: {_fmt(k, '.4f')}"
                    for p, k in zip(r["front"], ks, strict=True)
                )
            )
        if "reference" in r:
            ref, dom = r["reference"], r.get("dominates_reference")
            lines.append(
                f"      reference: objective {_fmt(ref['objective'], '.3g')} mm², "
                f"stiffness {_fmt(ref['stiffness'], '.4f')} N/mm; "
                + ("dominated" if dom else "NOT dominated")
            )
        lines += fitted_range_warning(r)
    return lines
