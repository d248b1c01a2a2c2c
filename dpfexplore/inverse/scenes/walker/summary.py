"""The text summary of a walker scene's legs (``dpfexplore design`` without ``--json``).

One block per leg: its stride against the monostable leg's, every unit's class, reset time and
inversion pressure, the requirements not met, the turning gait of a front leg.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ...report import fitted_range_warning, text_number
from ...spec import SceneSpec

__all__ = ["leg_lines", "summary_lines"]


def _fmt(value: Any, spec: str = ".4f") -> str:
    return text_number(value, spec, missing="-")


def summary_lines(spec: SceneSpec, rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The summary's lines of the ``--json`` rows ``rows``."""
    return leg_lines(rows)


def leg_lines(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The summary's lines of the ``--json`` rows ``rows`` (one block per leg)."""
    lines = []
    for r in rows:
        if r.get("design") is None:
            lines.append(f"  {r['leg']} leg: NOT found ({r.get('proof')})")
            continue
        met = sum(q["met"] for q in r["requirements"])
        lines.append(
            f"  {r['leg']} leg: stride {r['stride']:.3f} mm = {r['stride_ratio']:.2f} x the "
            f"monostable leg's ({r['monostable_stride']:.3f} mm); requirements met "
            f"{met}/{len(r['requirements'])}; wall {r['wall_s']:.2f} s"
        )
        for u in r["units"]:
            # a unit that never inverts has no class (not "flat") and no inversion pressure
            p_inv = u["inversion_pressure_MPa"]
            inverts = (
                f"inverts at {_fmt(p_inv, '.4f')} MPa"
                if isinstance(p_inv, int | float) and math.isfinite(p_inv)
                else "never inverts on the ramp"
            )
            lines.append(
                f"      {u['section']:>6} unit {u['unit']}: H {u['H']:.5f} t {u['t']:.4f}  "
                f"{u['class'] or 'not inverted':>12}  reset {_fmt(u['reset_time'], '.4f'):>8} s  "
                f"{inverts} (its section runs {u['phase']} at {u['pressure_MPa']:g} MPa)"
            )
        for q in r["requirements"]:
            if not q["met"]:
                lines.append(
                    f"      NOT MET: {q['zone']}: {q['requirement']} ({q['value']} vs {q['bound']})"
                )
        if "turning" in r:
            turn = r["turning"]
            figure = turn.get("timing_figure_t_end")
            seen = f"; the timing figure runs {figure:g} s" if figure else ""
            what = (
                f"inverts and is still inverted at the end of the stride run "
                f"({turn['t_end']:g} s{seen})"
                if turn["action_inverted_at_end"]
                else "inverts and resets within the run"
                if turn["action_inverts"]
                else "does NOT invert"
            )
            lines.append(
                f"      turning gait (phase 2 at the turning pressure): the action unit {what}; "
                f"stride {turn['stride']:.3f} mm"
            )
        lines += fitted_range_warning(r)
    return lines
