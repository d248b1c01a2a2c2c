"""The text summary of a pick-and-place scene's results (``dpfexplore design`` without ``--json``).

The screening and the reachable range of reset times, then one table row per result (a target
reset time, two units' times, or the difference front) with its reset times and classes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ...report import fitted_range_warning, text_number
from ...spec import SceneSpec

__all__ = ["summary_lines"]


def _fmt(value: Any, spec: str = ".4f") -> str:
    return text_number(value, spec, missing="-")


def summary_lines(spec: SceneSpec, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The summary's lines of the ``--json`` rows ``rows``."""
    lines = []
    r0 = rows[0] if rows else {}
    rng = (r0.get("reachable_range") or {}).get("all")
    fit = (r0.get("reachable_range") or {}).get("fitted_range")
    if r0:
        lines.append(
            f"  screening: {r0['screening']['note']}; {r0['screening']['designs']} designs, "
            f"{r0['screening']['wall_s']:.2f} s"
        )
    if rng:
        lines.append(
            f"  reachable reset times: {rng['min_s']:.3f} to {rng['max_s']:.3f} s"
            + (
                f" (inside the fitted range {fit['min_s']:.3f} to {fit['max_s']:.3f} s)"
                if fit
                else ""
            )
            + " on the screening grid; every time up to the horizon "
            f"({r0['reachable_range']['supremum_s']:g} s) is reachable: the reset time "
            "diverges at the bistable edge"
        )
    lines.append(
        f"  {'target s':>14}  {'H tip':>8}  {'t':>7}  {'reset s':>9}  {'error':>9}  "
        f"{'stiff N/mm':>10}  {'wall s':>6}  met"
    )
    for r in rows:
        d = r.get("design")
        h = d["H"][-1] if d else None
        t = d["t"] if d else None
        if r["objective_kind"] == "difference":
            lines.append(
                f"  {'max RT2-RT1':>14}  {_fmt(h)}  {_fmt(t)}  diff {_fmt(r.get('difference'))} s"
                f"  stiffness {_fmt(r.get('stiffness'), '.5f')}  wall {r['wall_s']:.2f}  "
                f"front of {len(r.get('front', []))}"
            )
        else:
            target = r["target_reset"]
            text = (
                ", ".join(f"{v:g}" for v in target) if isinstance(target, list) else f"{target:g}"
            )
            lines.append(
                f"  {text:>14}  {_fmt(h):>8}  {_fmt(t):>7}  {_fmt(r.get('reset_time')):>9}  "
                f"{_fmt(r.get('relative_error'), '.2e'):>9}  "
                f"{_fmt(r.get('stiffness'), '.5f'):>10}  "
                f"{r['wall_s']:6.2f}  {'yes' if r['reachable'] else 'NO'}"
            )
            if r.get("reset_times"):
                lines.append(f"      reset times {r['reset_times']}, classes {r['classes']}")
        lines += fitted_range_warning(r)
    return lines
