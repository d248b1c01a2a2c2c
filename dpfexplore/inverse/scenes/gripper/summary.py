"""The text summary of the gripper scene's result (``dpfexplore design`` without ``--json``).

The apertures, base and stiffness of the gripper, its tip unit's reset under the pulse, its
pressure windows, the reference's apertures and a fitted-range warning.
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
    lines = []
    for r in rows:
        ap = ", ".join(f"{a:.3f}" for a in r["apertures"])
        targets = ", ".join(f"{a:g}" for a in r["target"])
        lines.append(
            f"  apertures {ap} mm (targets {targets}), theta_B {r['theta_B_deg']:.3f}"
            f" deg, Base_L {r['base_L']:.3f} mm, stiffness {_fmt(r['stiffness'], '.5f')}"
            f" N/mm"
        )
        lines += fitted_range_warning(r, indent="  ")
        meta = r.get("metastability") or {}
        lines.append(
            f"  tip unit: reset after {_fmt(meta.get('reset_time_s'), '.4f')} s "
            f"({'ok' if meta.get('ok') else 'NOT metastable'})"
        )
        windows = "; ".join(
            "-" if w is None else f"{w[0]:.1f}-{w[1]:.1f}" for w in r["pressure_windows_kPa"] or []
        )
        lines.append(
            f"  pressure windows (kPa): {windows} "
            f"({'ok' if r.get('windows_ok') else 'NOT ok'}; "
            f"{r['pressure_windows_kPa_detail'].get('note')})"
        )
        if "reference" in r:
            ref = r["reference"]
            ap = ", ".join(f"{a:.3f}" for a in ref["apertures"])
            lines.append(
                f"  reference: apertures {ap} mm, stiffness {_fmt(ref['stiffness'], '.5f')} N/mm"
            )
    return lines
