"""The text summary of the gripper scene's result (``dpfexplore design`` without ``--json``).

The apertures, base and stiffness of the gripper, its tip unit's reset under the pulse, its
pressure windows, the reference's apertures and a fitted-range warning; with a sorting objective,
each class's margin and the re-verification's confusion table.
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
        if "sorting" in r:
            lines += sorting_lines(r["sorting"])
    return lines


def sorting_lines(s: Mapping[str, Any]) -> list[str]:
    """The sorting objective's lines: margins per class and the confusion table."""
    scene = ", ".join(f"{a:g}" for a in s["scene_apertures"])
    lines = [
        f"  sorting: margin {_fmt(s['margin'], '.4g')} (the scene's own design: "
        f"{_fmt(s['default_margin'], '.4g')}; {s['diameter_scale_mm']:g} mm of diameter counts "
        f"as {1e3 * s['mass_scale_kg']:g} g of mass); target apertures chosen "
        + ", ".join(f"{a:.3f}" for a in s["apertures"])
        + f" mm ([gripper] asks {scene}); {s['search']['evaluations']} margins searched",
        f"  {'class':<12}{'outcome':<18}{'size':>9}{'mass':>9}{'margin':>9}  sorted",
        f"  {'':<12}{'':<18}{'mm':>9}{'g':>9}{'':>9}",
    ]
    for c in s["classes"]:
        mass = c["mass_margin_kg"]
        lines.append(
            f"  {c['name']:<12}{c['label']:<18}{_fmt(c['size_margin_mm'], '9.3f'):>9}"
            f"{_fmt(None if mass is None else 1e3 * mass, '9.3f'):>9}"
            f"{_fmt(c['margin'], '9.3f'):>9}  {'yes' if s['correct'][c['name']] else 'NO'}"
        )
    n = s["samples_per_class"]
    tip = s["tip_reset_s"]
    lines.append(
        f"  re-verified: gripper.toml read back and re-solved; sort on {n} objects per class "
        f"(edges included), mu {s['mu']:g}, lift {s['lift_s']:g} s, tip unit resets after "
        f"{_fmt(tip, '.4f')} s ({'used' if s['tip_lasts'] else 'not used'})"
    )
    outcomes = sorted({k for row in s["confusion"].values() for k in row})
    lines.append("  confusion (rows: class; columns: the loop's outcome)")
    first = max(12, *(len(name) for name in s["confusion"]))
    lines.append("  " + f"{'':<{first}}" + "".join(f"{c:>16}" for c in outcomes))
    for name, row in s["confusion"].items():
        lines.append("  " + f"{name:<{first}}" + "".join(f"{row.get(c, 0):>16}" for c in outcomes))
    lines.append(
        f"  sorting objective {'met' if s['met'] else 'NOT met'}: "
        + (
            "every class's objects sorted to an outcome of their own"
            if s["met"]
            else "some class's objects are not all sorted to one held outcome of their own"
        )
    )
    return lines
