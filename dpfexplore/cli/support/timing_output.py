"""Text summaries of the timing scenes for ``dpfexplore design`` (pick-and-place, walker leg)."""

from __future__ import annotations

import math

__all__ = ["print_timing_summary"]


def _t(value, spec: str = ".4f") -> str:
    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    return format(value, spec)


def _flag(row) -> None:
    if row.get("fitted_range") is False:
        print(f"      warning: {row['fitted_range_note']}")


def print_timing_summary(spec, rows) -> None:
    """Print one block per result row."""
    if spec.kind == "pickplace":
        _pickplace(spec, rows)
    else:
        _walker(rows)


def _pickplace(spec, rows) -> None:
    r0 = rows[0] if rows else {}
    rng = (r0.get("reachable_range") or {}).get("all")
    fit = (r0.get("reachable_range") or {}).get("fitted_range")
    if r0:
        print(
            f"  screening: {r0['screening']['note']}; {r0['screening']['designs']} designs, "
            f"{r0['screening']['wall_s']:.2f} s"
        )
    if rng:
        print(
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
    print(
        f"  {'target s':>14}  {'H tip':>8}  {'t':>7}  {'reset s':>9}  {'error':>9}  "
        f"{'stiff N/mm':>10}  {'wall s':>6}  met"
    )
    for r in rows:
        d = r.get("design")
        h = d["H"][-1] if d else None
        t = d["t"] if d else None
        if r["objective_kind"] == "difference":
            print(
                f"  {'max RT2-RT1':>14}  {_t(h)}  {_t(t)}  diff {_t(r.get('difference'))} s"
                f"  stiffness {_t(r.get('stiffness'), '.5f')}  wall {r['wall_s']:.2f}  "
                f"front of {len(r.get('front', []))}"
            )
        else:
            target = r["target_reset"]
            text = (
                ", ".join(f"{v:g}" for v in target) if isinstance(target, list) else f"{target:g}"
            )
            print(
                f"  {text:>14}  {_t(h):>8}  {_t(t):>7}  {_t(r.get('reset_time')):>9}  "
                f"{_t(r.get('relative_error'), '.2e'):>9}  {_t(r.get('stiffness'), '.5f'):>10}  "
                f"{r['wall_s']:6.2f}  {'yes' if r['reachable'] else 'NO'}"
            )
            if r.get("reset_times"):
                print(f"      reset times {r['reset_times']}, classes {r['classes']}")
        _flag(r)


def _walker(rows) -> None:
    for r in rows:
        if r.get("design") is None:
            print(f"  {r['leg']} leg: NOT found ({r.get('proof')})")
            continue
        met = sum(q["met"] for q in r["requirements"])
        print(
            f"  {r['leg']} leg: stride {r['stride']:.3f} mm = {r['stride_ratio']:.2f} x the "
            f"monostable leg's ({r['monostable_stride']:.3f} mm); requirements met "
            f"{met}/{len(r['requirements'])}; wall {r['wall_s']:.2f} s"
        )
        for u in r["units"]:
            # a unit that never inverts has no class (not "flat") and no inversion pressure
            p_inv = u["inversion_pressure_MPa"]
            inverts = (
                f"inverts at {_t(p_inv, '.4f')} MPa"
                if isinstance(p_inv, int | float) and math.isfinite(p_inv)
                else "never inverts on the ramp"
            )
            print(
                f"      {u['section']:>6} unit {u['unit']}: H {u['H']:.5f} t {u['t']:.4f}  "
                f"{u['class'] or 'not inverted':>12}  reset {_t(u['reset_time'], '.4f'):>8} s  "
                f"{inverts} (its section runs {u['phase']} at {u['pressure_MPa']:g} MPa)"
            )
        for q in r["requirements"]:
            if not q["met"]:
                print(
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
            print(
                f"      turning gait (phase 2 at the turning pressure): the action unit {what}; "
                f"stride {turn['stride']:.3f} mm"
            )
        _flag(r)
