"""The walker-leg scene's groundwork: heights that are metastable in this model, and legs.

The implementation's leg (MODEL.md §10; ``dpfexplore/examples/walker-leg.toml``): U_L = 6.5,
U_sep = 1, t_lim = 1, E = 26; phase 1 (purple zone) P0 at tau = 0, 0.1, 1.1, 1.2 s, phase 2
(green zone) at tau = 1.1, 1.2, 2.2, 2.3 s; walking pressure 0.4 MPa. Each section may have its
own dome thickness t here (each is its own finger). Three maps over (H, t):

* purple zone (section 1: two units of height H) under phase 1: each unit's class and reset
  time, and its inversion pressure (slow ramps, :mod:`dpfexplore.solvers.dynamics.ramp`); and, since
  equal heights cannot keep both units inverted long, the two heights apart at a few t;
* action section (section 3: the action unit H then three units of 4.5 mm) under phase 2 at the
  walking pressure: the action unit's class and reset time, its inversion
  pressure and that of the 4.5 mm units once it has inverted; per t, the heights whose reset
  exceeds a gait cycle (bisection to the bistable edge);
* then legs built from what the maps allow, simulated with ``simulate_leg``, their stride
  against the implementation's legs at the same gait.

Requirements used (the scene's, made concrete): the purple zone keeps the leg lifted
until the other phase has actuated: both units invert at the walking pressure and the first to
reset does so >= 1.0 s after phase 1 ends (phase 2's release starts 1.0 s after it); a front
leg's action unit resets >= 2.2 s after its phase ends (a full gait cycle: phase 1 repeats every
2.2 s) and inverts at a higher pressure than every purple unit.

    PYTHONPATH=. .venv/bin/python scripts/walker_leg_map.py   # -> results/reports/
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm
from matplotlib.figure import Figure

from dpfexplore import Design, DesignBatch, PressureProfile, reset_times_batch
from dpfexplore.bench._common import machine_info
from dpfexplore.examples import example_path
from dpfexplore.plotting.leg import plot_tip_paths
from dpfexplore.solvers.dynamics.ramp import inversion_pressures
from dpfexplore.solvers.legs.leg import load_leg, simulate_leg

OUT = Path("results") / "reports"
NAME = "walker-leg-map"
P_WALK = 0.4
PHASE1 = (0.0, 0.1, 1.1, 1.2)
PHASE2 = (1.1, 1.2, 2.2, 2.3)
LIFT = PHASE2[2] - PHASE1[3]  # s after phase 1 ends: phase 2's release starts
CYCLE = 2.2  # s: phase 1 repeats
HORIZON = 12.0  # s after each phase ends
H_PURPLE = np.round(np.arange(2.0, 3.6 + 1e-9, 0.02), 4)
H_ACTION = np.round(np.arange(2.0, 4.5 + 1e-9, 0.025), 4)
T_GRID = np.round(np.arange(0.55, 1.0 + 1e-9, 0.025), 4)


def section(H, t: float) -> Design:
    """A section of the walker's leg: heights H, dome thickness t."""
    return Design(H=list(H), U_L=6.5, U_sep=1.0, t=float(t), t_lim=1.0, E=26.0)


def run_grid(heights, make, tau, pressures):
    """Reset times and classes under pulses at each pressure, and ramp inversion pressures."""
    hh, tt = np.meshgrid(heights, T_GRID, indexing="ij")
    designs = [make(h, t) for h, t in zip(hh.ravel(), tt.ravel(), strict=True)]
    batch = DesignBatch.from_designs(designs)
    n_units = designs[0].n_units
    out = {"h": hh, "t": tt, "n": len(designs)}
    start = time.perf_counter()
    for P0 in pressures:
        profile = PressureProfile(P0=P0, tau=tau)
        res = reset_times_batch(batch, profile, t_end=tau[3] + HORIZON)
        out[P0] = {
            "reset": res["reset_time"][:, :n_units].reshape(*hh.shape, n_units),
            "cls": res["unit_class"][:, :n_units].reshape(*hh.shape, n_units),
        }
    out["wall_pulses"] = time.perf_counter() - start
    start = time.perf_counter()
    out["p_inv"] = inversion_pressures(batch)[:, :n_units].reshape(*hh.shape, n_units)
    out["wall_ramps"] = time.perf_counter() - start
    return out


H1_GRID = np.round(np.arange(2.0, 3.2 + 1e-9, 0.02), 4)
H2_GRID = np.round(np.arange(1.8, 3.0 + 1e-9, 0.02), 4)
T_APART = (0.6, 0.65, 0.7)


def purple_apart(t: float):
    """First and last reset of the purple zone over (H_1, H_2) at thickness t (walking P)."""
    h1, h2 = np.meshgrid(H1_GRID, H2_GRID, indexing="ij")
    designs = [section([a, b], t) for a, b in zip(h1.ravel(), h2.ravel(), strict=True)]
    profile = PressureProfile(P0=P_WALK, tau=PHASE1)
    res = reset_times_batch(DesignBatch.from_designs(designs), profile, t_end=PHASE1[3] + HORIZON)
    cls, reset = res["unit_class"][:, :2], res["reset_time"][:, :2]
    both = np.all(cls == 1, axis=1)
    first = np.where(both, reset.min(axis=1), np.nan).reshape(h1.shape)
    last = np.where(both, reset.max(axis=1), np.nan).reshape(h1.shape)
    return {"t": t, "h1": h1, "h2": h2, "first": first, "last": last}


def edge_windows(t_values, threshold: float, P0: float):
    """Per t: the action unit's bistable edge and the lowest H whose reset reaches threshold.

    Bisection on H (all t at once, one batch per step) between the grid's last metastable and
    first bistable heights, then between a metastable height below the threshold and the edge.
    """
    profile = PressureProfile(P0=P0, tau=PHASE2)

    def evaluate(heights, ts):
        designs = [section([h, 4.5, 4.5, 4.5], t) for h, t in zip(heights, ts, strict=True)]
        res = reset_times_batch(
            DesignBatch.from_designs(designs), profile, t_end=PHASE2[3] + HORIZON
        )
        return res["unit_class"][:, 0], res["reset_time"][:, 0], res["unit_class"][:, 1:4]

    grid_h = np.repeat(H_ACTION[None, :], len(t_values), axis=0)
    cls, reset, _ = evaluate(grid_h.ravel(), np.repeat(t_values, len(H_ACTION)))
    cls, reset = cls.reshape(grid_h.shape), reset.reshape(grid_h.shape)
    rows = []
    for j, t in enumerate(t_values):
        meta = np.flatnonzero(cls[j] == 1)
        bist = np.flatnonzero(cls[j] == 0)
        above = bist[bist > meta[-1]] if meta.size else bist[:0]
        if not meta.size or not above.size:
            rows.append({"t": float(t), "edge": None})
            continue
        below = meta[reset[j, meta] < threshold]
        rows.append(
            {
                "t": float(t),
                "lo": float(H_ACTION[meta[-1]]),
                "hi": float(H_ACTION[above[0]]),
                "lo_T": float(H_ACTION[below[-1]]) if below.size else None,
            }
        )
    live = [r for r in rows if "lo" in r]
    for _ in range(18):  # the edge: metastable at lo, bistable at hi
        mids = [(r["lo"] + r["hi"]) / 2 for r in live]
        c, _, _ = evaluate(mids, [r["t"] for r in live])
        for r, mid, code in zip(live, mids, c, strict=True):
            r["lo" if code == 1 else "hi"] = mid
    for r in live:
        r["edge"] = r["lo"]
        r["top"] = r["lo"]
    live = [r for r in live if r["lo_T"] is not None]
    for _ in range(18):  # the threshold: reset < T at lo_T, >= T at top
        mids = [(r["lo_T"] + r["top"]) / 2 for r in live]
        c, value, _ = evaluate(mids, [r["t"] for r in live])
        for r, mid, code, v in zip(live, mids, c, value, strict=True):
            if code == 1 and v >= threshold:
                r["top"] = mid
            else:
                r["lo_T"] = mid
    for r in live:
        r["h_T"] = r["top"]
        c, value, rest = evaluate([r["h_T"], r["edge"]], [r["t"]] * 2)
        r["reset_T"], r["reset_edge"] = float(value[0]), float(value[1])
        r["rest_flat"] = bool(np.all(rest[0] == -1))
    return rows


def pick_apart(maps):
    """Purple heights whose first reset reaches LIFT and whose last is soonest after it."""
    best = None
    for m in maps:
        ok = m["first"] >= LIFT
        if not ok.any():
            continue
        i = np.nanargmin(np.where(ok, m["last"], np.nan))
        i = np.unravel_index(i, ok.shape)
        candidate = (float(m["last"][i]), float(m["h1"][i]), float(m["h2"][i]), m["t"])
        if best is None or candidate < best:
            best = candidate
    return None if best is None else {"H": (best[1], best[2]), "t": best[3]}


def leg_with(purple, action, t_purple, t_action, name):
    """The example leg with the purple heights (a pair) and the action unit replaced."""
    leg = load_leg(example_path("walker-leg"))
    leg = leg.with_design("purple", H=list(purple), t=t_purple)
    leg = leg.with_design("action", H=[action, 4.5, 4.5, 4.5], t=t_action)
    from dataclasses import replace

    return replace(leg, name=name)


def draw(purple, apart, action, legs, path: Path) -> None:
    """Maps of both zones and the tip paths, one PNG."""
    fig = Figure(figsize=(16, 13), layout="constrained")
    axes = fig.subplots(3, 3)
    palette = ListedColormap(["0.85", "tab:blue", "tab:green", "tab:orange", "tab:gray"])
    norm = BoundaryNorm([-1.5, -0.5, 0.5, 1.5, 2.5, 3.5], palette.N)
    labels = ["never inv.", "bistable", "metastable", "monostable", "no contact"]
    both = np.all(purple[P_WALK]["cls"] == 1, axis=-1)
    first = np.where(both, np.min(purple[P_WALK]["reset"], axis=-1), np.nan)
    ax = axes[0, 0]
    mesh = ax.pcolormesh(
        purple["h"],
        purple["t"],
        np.ma.masked_invalid(first),
        norm=LogNorm(0.05, 10),
        shading="nearest",
    )
    fig.colorbar(mesh, ax=ax, label="first purple unit's reset (s)")
    ax.set_title(
        f"purple zone, equal heights, {P_WALK} MPa\n(white: not both units metastable)",
        fontsize="small",
    )
    ax.set_xlabel("H_1 = H_2 (mm)")
    ax.set_ylabel("t (mm)")
    ax = axes[0, 1]
    mesh = ax.pcolormesh(
        purple["h"],
        purple["t"],
        purple[P_WALK]["cls"][..., 1],
        cmap=palette,
        norm=norm,
        shading="nearest",
    )
    fig.colorbar(mesh, ax=ax, ticks=[-1, 0, 1, 2, 3]).ax.set_yticklabels(labels)
    ax.set_title(f"purple unit 2 (tip), equal heights, at {P_WALK} MPa", fontsize="small")
    ax.set_xlabel("H_1 = H_2 (mm)")
    ax.set_ylabel("t (mm)")
    ax = axes[0, 2]
    m = apart[0]
    mesh = ax.pcolormesh(
        m["h1"],
        m["h2"],
        np.ma.masked_invalid(m["first"]),
        norm=LogNorm(0.05, 10),
        shading="nearest",
    )
    fig.colorbar(mesh, ax=ax, label="first purple unit's reset (s)")
    ax.contour(m["h1"], m["h2"], np.nan_to_num(m["first"], nan=0.0), levels=[LIFT], colors="r")
    ax.set_xlabel("H_1 (mm)")
    ax.set_ylabel("H_2 (mm)")
    ax.set_title(
        f"purple zone, heights apart, t = {m['t']:g} (red: first reset {LIFT:g} s)",
        fontsize="small",
    )
    ax = axes[1, 0]
    meta = action[P_WALK]["cls"][..., 0] == 1
    mesh = ax.pcolormesh(
        action["h"],
        action["t"],
        np.ma.masked_invalid(np.where(meta, action[P_WALK]["reset"][..., 0], np.nan)),
        norm=LogNorm(0.05, 10),
        shading="nearest",
    )
    fig.colorbar(mesh, ax=ax, label="action unit reset (s)")
    ax.set_title(f"action unit at {P_WALK} MPa (white: not metastable)", fontsize="small")
    ax = axes[1, 1]
    mesh = ax.pcolormesh(
        action["h"], action["t"], action["p_inv"][..., 0], shading="nearest", cmap="magma"
    )
    fig.colorbar(mesh, ax=ax, label="action unit inversion pressure (MPa)")
    ax.set_title("action unit inversion pressure", fontsize="small")
    ax = axes[1, 2]
    mesh = ax.pcolormesh(
        action["h"],
        action["t"],
        action[P_WALK]["cls"][..., 1],
        cmap=palette,
        norm=norm,
        shading="nearest",
    )
    fig.colorbar(mesh, ax=ax, ticks=[-1, 0, 1, 2, 3]).ax.set_yticklabels(labels)
    ax.set_title(f"first 4.5 mm unit at {P_WALK} MPa (must stay flat)", fontsize="small")
    for ax in axes[1]:
        ax.set_xlabel("action unit H (mm)")
        ax.set_ylabel("t (mm)")
    short = {
        "implementation H_p = 1.1": "impl. H_p 1.1",
        "implementation H_p = 2.5": "impl. H_p 2.5",
        "designed front leg": "front",
        "designed middle leg (monostable action unit)": "middle",
    }
    plot_tip_paths(
        [leg for _, leg in legs], axes[2, :2], labels=[short.get(label, label) for label, _ in legs]
    )
    ax = axes[2, 2]
    for i, (label, leg) in enumerate(legs):
        ax.plot(
            leg.t,
            np.linalg.norm(leg.tip_path, axis=1),
            color=f"C{i % 10}",
            label=short.get(label, label),
        )
    for when in (PHASE1[3], PHASE2[3]):
        ax.axvline(when, color="0.6", linewidth=0.6)
    ax.set_xlabel("time (s); grey: end of phase 1, of phase 2")
    ax.set_ylabel("tip distance from its start (mm)")
    ax.legend(fontsize="small")
    fig.savefig(path, dpi=100)


def report(purple, apart, action, windows, picks, legs) -> str:
    """The markdown report."""
    info = machine_info()
    both = np.all(purple[P_WALK]["cls"] == 1, axis=-1)
    first = np.where(both, np.min(purple[P_WALK]["reset"], axis=-1), np.nan)
    lines = [
        "# Walker leg: heights that are metastable in this model",
        "",
        "Groundwork for issue 14's walker-leg scene (MODEL.md §10). Sections of the "
        "implementation's leg (U_L = 6.5, U_sep = 1, t_lim = 1, E = 26), each with its own dome "
        f"thickness t here; walking pressure {P_WALK} MPa, phase 1 tau = {PHASE1} s, phase 2 "
        f"tau = {PHASE2} s; reset horizon {HORIZON:g} s after each phase. Inversion pressures "
        "from two slow ramps extrapolated to the quasi-static fold "
        "(`dpfexplore.solvers.dynamics.ramp.inversion_pressures`, within about 1 %). "
        f"Grids: purple H = {H_PURPLE[0]}..{H_PURPLE[-1]} step 0.02 (and H_1, H_2 apart on "
        f"{len(H1_GRID)} x {len(H2_GRID)} at t = {', '.join(f'{t:g}' for t in T_APART)}), "
        f"action H = {H_ACTION[0]}..{H_ACTION[-1]} step 0.025, t = {T_GRID[0]}..{T_GRID[-1]} "
        f"step 0.025. Wall: grids {purple['wall_pulses'] + action['wall_pulses']:.0f} s, ramps "
        f"{purple['wall_ramps'] + action['wall_ramps']:.0f} s, on {info['cores']} cores "
        f"({info['cpu']}, {info['date']}; shared with other jobs). Heights below 3 mm lie "
        "outside the range the closed forms were fitted on (MODEL.md §3): every purple design "
        "here does.",
        "",
        "Requirements as measured here: the purple zone keeps the leg lifted while the other "
        f"phase actuates: both units invert at {P_WALK} MPa and the first to reset does so "
        f">= {LIFT:g} s after phase 1 ends (phase 2's release starts then); a front leg's "
        f"action unit resets >= {CYCLE:g} s after phase 2 ends (a full gait cycle) and inverts "
        "at a higher pressure than the purple zone.",
        "",
        "Reproduce: `PYTHONPATH=. .venv/bin/python scripts/walker_leg_map.py`.",
        "",
        f"![maps]({NAME}.png)",
        "",
        "## Purple zone (section 1, two units)",
        "",
        f"- Equal heights (the implementation's): both units inverted and metastable at "
        f"{P_WALK} MPa on {int(np.isfinite(first).sum())} of {purple['n']} grid designs, "
        f"t {np.nanmin(np.where(both, purple['t'], np.nan)):.3f}-"
        f"{np.nanmax(np.where(both, purple['t'], np.nan)):.3f} mm; the first unit (the base) "
        f"resets at most {np.nanmax(first):.3f} s after phase 1: the tip unit turns bistable "
        "(or stops inverting) at a lower height than the base unit, so equal heights cannot "
        f"keep both inverted for {LIFT:g} s.",
        f"- At t = 1.0 (the implementation's thickness) no height gives a metastable purple "
        f"zone at {P_WALK} MPa: " + t1_purple_text(purple) + ".",
        "- Heights apart (H_1 for the base unit, H_2 for the tip unit), both metastable:",
        "",
        "| t mm | designs with both metastable | first reset >= 0.3 s | >= 0.5 s | "
        f">= {LIFT:g} s | >= 2 s | longest first reset s (H_1, H_2) |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in apart:
        f = m["first"]
        i = np.unravel_index(np.nanargmax(f), f.shape) if np.isfinite(f).any() else None
        best = f"{f[i]:.3f} ({m['h1'][i]:.2f}, {m['h2'][i]:.2f})" if i is not None else "-"
        lines.append(
            f"| {m['t']:g} | {int(np.isfinite(f).sum())} | {int((f >= 0.3).sum())} | "
            f"{int((f >= 0.5).sum())} | {int((f >= LIFT).sum())} | "
            f"{int((f >= 2.0).sum())} | {best} |"
        )
    lines += [
        "",
        "  The resets diverge at each unit's bistable edge, so long resets sit in thin slivers "
        f"of the (H_1, H_2) plane (grid step 0.02 mm): a scene that asks for >= {LIFT:g} s "
        "must place both heights within a few hundredths of a millimetre of their edges.",
        "",
        "## Action unit (section 3: the action unit, then three 4.5 mm units)",
        "",
        "- The 4.5 mm units must stay flat at the walking pressure; once the action unit has "
        "inverted, the first of them inverts at " + unit2_text(action) + ": at "
        f"{P_WALK} MPa they stay flat only for t above about 0.85 mm.",
        f"- Per t, the bistable edge of the action unit at {P_WALK} MPa (bisection, 18 steps) "
        f"and the lowest height whose reset reaches {CYCLE:g} s (a gait cycle):",
        "",
        f"| t mm | edge H mm | H for reset {CYCLE:g} s | window mm | reset there s | "
        f"4.5 mm units flat at {P_WALK} MPa | action inversion pressure MPa |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in windows:
        if r.get("edge") is None:
            lines.append(f"| {r['t']:g} | no metastable-to-bistable edge on the grid | | | | | |")
            continue
        if "h_T" not in r:
            lines.append(f"| {r['t']:g} | {r['edge']:.4f} | not bracketed | | | | |")
            continue
        j = int(np.argmin(np.abs(T_GRID - r["t"])))
        i = int(np.argmin(np.abs(H_ACTION - r["h_T"])))
        lines.append(
            f"| {r['t']:g} | {r['edge']:.4f} | {r['h_T']:.4f} | "
            f"{r['edge'] - r['h_T']:.4f} | {r['reset_T']:.3f} | "
            f"{'yes' if r['rest_flat'] else 'no'} | "
            f"{action['p_inv'][i, j, 0]:.3f} |"
        )
    lines += [
        "",
        "- Pressure order: " + order_text(purple, apart, action) + ".",
        "",
        "## Legs built from the maps (the implementation's gait: one cycle, 5 s)",
        "",
        "| leg | purple H, t | action H, t | purple classes; resets s | action class; reset s |"
        " extent x, y, z mm | stride (path diameter) mm | fitted range |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, leg in legs:
        s = leg.sections
        p, a = s[0].result, s[2].result
        d0, d2 = s[0].section.design, s[2].section.design
        lines.append(
            f"| {label} | {', '.join(f'{h:g}' for h in d0.H)}; {d0.t:g} | "
            f"{d2.H[0]:g}; {d2.t:g} | "
            f"{', '.join(c or '-' for c in p.unit_class)}; {fmt(p.reset_time)} | "
            f"{a.unit_class[0] or '-'}; {fmt(a.reset_time[:1])} | "
            f"{', '.join(f'{v:.2f}' for v in leg.extent)} | {leg.stride:.2f} | "
            f"{'yes' if leg.fitted_range else 'no'} |"
        )
    base = dict(legs)
    for label, leg in legs:
        if label.startswith("designed"):
            ratios = ", ".join(
                f"{leg.stride / base[ref].stride:.2f}x the {ref} leg's"
                for ref in base
                if ref.startswith("implementation")
            )
            lines.append(f"\n{label}: stride {ratios}.")
    shown = {k: v for k, v in picks.items() if k != "pressures"}
    lines += ["", "Picks: " + "; ".join(f"{k}: {v}" for k, v in shown.items()) + "."]
    if "pressures" in picks:
        pp, pa = picks["pressures"]
        lines += [
            "",
            f"Inversion pressures of the picks: purple units {pp[0]:.3f} and "
            f"{pp[1]:.3f} MPa; action unit {pa[0]:.3f} MPa, then the 4.5 mm units "
            f"{pa[1]:.3f} MPa. "
            + (
                f"The action unit inverts above the whole purple zone: a walking pressure "
                f"in ({max(pp[:2]):.3f}, {pa[0]:.3f}) MPa would leave it flat until a "
                f"raise to ({pa[0]:.3f}, {pa[1]:.3f}) MPa (the purple zone's classes at "
                "that lower pressure are not mapped here)."
                if pa[0] > max(pp[:2])
                else "The action unit inverts below the purple zone's second unit, so no "
                "walking pressure separates them with these picks."
            ),
        ]
    return "\n".join(lines) + "\n"


def fmt(values) -> str:
    """Reset times as text."""
    return ", ".join("-" if np.isnan(v) else ("inf" if np.isinf(v) else f"{v:.3f}") for v in values)


def t1_purple_text(m) -> str:
    """What the purple zone does at t = 1.0."""
    j = int(np.argmin(np.abs(T_GRID - 1.0)))
    cls = m[P_WALK]["cls"][:, j]
    names = {-1: "never inverted", 0: "bistable", 1: "metastable", 2: "monostable", 3: "no contact"}
    parts = []
    for pattern in np.unique(cls, axis=0):
        rows = np.all(cls == pattern, axis=1)
        hs = H_PURPLE[rows]
        parts.append(f"H {hs.min():.2f}-{hs.max():.2f}: {'/'.join(names[int(c)] for c in pattern)}")
    return "; ".join(parts)


def unit2_text(m) -> str:
    """Inversion pressure of the first 4.5 mm unit, at a few t."""
    parts = []
    for t in (0.6, 0.7, 0.8, 0.9, 1.0):
        j = int(np.argmin(np.abs(T_GRID - t)))
        parts.append(f"{np.nanmedian(m['p_inv'][:, j, 1]):.3f} MPa at t = {T_GRID[j]:g}")
    return ", ".join(parts)


def order_text(purple, apart, action) -> str:
    """Inversion pressures of the purple zone against the action unit's."""
    both = np.all(purple[P_WALK]["cls"] == 1, axis=-1)
    p_purple = np.nanmax(purple["p_inv"], axis=-1)[both]
    meta = action[P_WALK]["cls"][..., 0] == 1
    p_action = action["p_inv"][..., 0][meta]
    text = (
        f"over the equal-height purple zones that work at {P_WALK} MPa, inverting both "
        f"units takes {np.nanmin(p_purple):.3f}-{np.nanmax(p_purple):.3f} MPa; a metastable "
        f"action unit inverts at {np.nanmin(p_action):.3f}-{np.nanmax(p_action):.3f} MPa "
        f"(all t). Every metastable action unit thus inverts below the walking pressure: "
        "at walking pressure it is inverted in every cycle, and raising the pressure adds "
        "nothing. For the paper's turning (walking pressure between the purple zone's and "
        "the action unit's inversion pressures) the action unit needs a higher inversion "
        "pressure than any metastable height gives at t <= 1 in this layout; a lower walking "
        "pressure, a thicker action dome (t > 1, outside the fitted range) or an action unit "
        "placed elsewhere in its section are what a scene could vary"
    )
    return text


def main() -> int:
    """Maps, legs, figure and report."""
    OUT.mkdir(parents=True, exist_ok=True)
    purple = run_grid(H_PURPLE, lambda h, t: section([h, h], t), PHASE1, (P_WALK,))
    print(f"purple: {purple['wall_pulses']:.1f} + {purple['wall_ramps']:.1f} s", file=sys.stderr)
    apart = [purple_apart(t) for t in T_APART]
    action = run_grid(H_ACTION, lambda h, t: section([h, 4.5, 4.5, 4.5], t), PHASE2, (P_WALK,))
    print(f"action: {action['wall_pulses']:.1f} + {action['wall_ramps']:.1f} s", file=sys.stderr)
    windows = edge_windows(T_GRID, CYCLE, P_WALK)
    purple_pick = pick_apart(apart)
    fits = [r for r in windows if r.get("h_T") is not None and r["rest_flat"]]
    action_pick = None
    if fits:
        r = max(fits, key=lambda r: r["t"])
        # a little closer to the edge than the threshold height: reset above a cycle
        action_pick = {"H": r["h_T"] + 0.25 * (r["edge"] - r["h_T"]), "t": r["t"]}
    picks = {"purple": purple_pick, "action": action_pick}
    if purple_pick and action_pick:
        batch = DesignBatch.from_designs(
            [
                section(purple_pick["H"], purple_pick["t"]),
                section([action_pick["H"], 4.5, 4.5, 4.5], action_pick["t"]),
            ]
        )
        pressures = inversion_pressures(batch)
        picks["pressures"] = (pressures[0, :2], pressures[1, :2])
    legs = [
        ("implementation H_p = 1.1", simulate_leg(load_leg(example_path("walker-leg")))),
        ("implementation H_p = 2.5", simulate_leg(load_leg(example_path("walker-leg-2.5")))),
    ]
    if purple_pick:
        hp, tp = purple_pick["H"], purple_pick["t"]
        if action_pick:
            legs.append(
                (
                    "designed front leg",
                    simulate_leg(leg_with(hp, action_pick["H"], tp, action_pick["t"], "front")),
                )
            )
        legs.append(
            (
                "designed middle leg (monostable action unit)",
                simulate_leg(leg_with(hp, 3.0, tp, 1.0, "middle")),
            )
        )
    draw(purple, apart, action, legs, OUT / f"{NAME}.png")
    (OUT / f"{NAME}.md").write_text(report(purple, apart, action, windows, picks, legs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
