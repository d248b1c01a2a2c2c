"""The pick-and-place scene's groundwork: reset times over (H_5 = H_6, t), and designs on them.

The paper's six-unit finger (MODEL.md §9: H_1..H_4 = 4.0, 4.5, 5.0, 5.0, U_sep = 1, U_L = 6,
t_lim = 1, E = 26) with the two tip units tied, ``H_5 = H_6 = h``, under the implementation's
pulse (P0 = 0.7 MPa, tau = 0, 1, 5, 5.1 s, 15 s horizon). One ``reset_times_batch`` call over a
grid of (h, t); then, for each target reset time, a design on the map's contour refined by
bisection on h with ``simulate`` (the full model) and verified.

    PYTHONPATH=. .venv/bin/python scripts/pickplace_reset_map.py   # -> results/reports/
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm
from matplotlib.figure import Figure

from dpfexplore import Design, DesignBatch, PressureProfile, reset_times_batch, simulate
from dpfexplore.bench._common import machine_info
from dpfexplore.solvers.dynamics.simulate import CLASS_NAMES

CODES = {name: code for code, name in CLASS_NAMES.items()}

OUT = Path("results") / "reports"
NAME = "pickplace-reset-map"
PULSE = PressureProfile(P0=0.7, tau=(0.0, 1.0, 5.0, 5.1))
T_END = 15.0
H_GRID = np.round(np.arange(2.0, 4.0 + 1e-9, 0.02), 4)
T_GRID = np.round(np.arange(0.5, 1.0 + 1e-9, 0.01), 4)
TARGETS = (0.3, 1.0, 2.0, 3.0)
PAPER = (3.0, 0.83)  # the paper's H_5 = H_6 and t


def finger(h: float, t: float) -> Design:
    """The paper's pick-and-place finger with H_5 = H_6 = h and dome thickness t."""
    return Design(H=[4.0, 4.5, 5.0, 5.0, h, h], U_L=6.0, U_sep=1.0, t=t, t_lim=1.0, E=26.0)


def last_reset(reset: np.ndarray, classes: np.ndarray, *, metastable_only: bool) -> np.ndarray:
    """Reset time of the last tip unit (5 or 6) to reset, over the last axis of 6 units.

    ``metastable_only``: only metastable units count (the scene's default objective; NaN where
    neither is metastable); otherwise every unit that inverted and came back counts (a
    continuous field across the 0.05 s class threshold, used to bracket targets).
    """
    tip_reset, tip_cls = reset[..., 4:6], classes[..., 4:6]
    keep = (tip_cls == 1) if metastable_only else np.isin(tip_cls, (1, 2))
    times = np.where(keep, tip_reset, -np.inf)
    out = np.max(times, axis=-1)
    return np.where(np.isfinite(out), out, np.nan)


def compute_map():
    """Reset times, classes and final states over the grid (one batch call)."""
    hh, tt = np.meshgrid(H_GRID, T_GRID, indexing="ij")
    designs = [finger(h, t) for h, t in zip(hh.ravel(), tt.ravel(), strict=True)]
    start = time.perf_counter()
    out = reset_times_batch(DesignBatch.from_designs(designs), PULSE, t_end=T_END)
    wall = time.perf_counter() - start
    shape = hh.shape
    reset = out["reset_time"][:, :6].reshape(*shape, 6)
    classes = out["unit_class"][:, :6].reshape(*shape, 6)
    return {
        "h": hh,
        "t": tt,
        "reset": reset,
        "classes": classes,
        "status": out["status"].reshape(shape),
        "final": out["final_state"].reshape(shape),
        "holds": np.all(classes[..., :4] == 0, axis=-1),
        "last": last_reset(reset, classes, metastable_only=True),
        "field": last_reset(reset, classes, metastable_only=False),
        "wall": wall,
        "n": len(designs),
    }


def full_model(h: float, t: float):
    """Last metastable reset, the continuous field, classes and whether units 1-4 hold."""
    run = simulate(finger(h, t), PULSE, t_end=T_END, n_samples=0)
    classes = np.array([CODES[c] for c in run.unit_class])
    return (
        float(last_reset(run.reset_time, classes, metastable_only=True)),
        float(last_reset(run.reset_time, classes, metastable_only=False)),
        run.unit_class,
        bool(np.all(classes[:4] == 0)),
    )


def brackets(m, target: float):
    """Grid intervals along h where the field crosses ``target`` with units 1-4 holding."""
    f, ok = m["field"], m["holds"]
    found = []
    for j in range(len(T_GRID)):
        for i in range(len(H_GRID) - 1):
            a, b = f[i, j], f[i + 1, j]
            if (
                ok[i, j]
                and ok[i + 1, j]
                and np.isfinite(a)
                and np.isfinite(b)
                and (a - target) * (b - target) <= 0
            ):
                found.append((i, j))
    return found


def hit_target(m, target: float):
    """One design with the target reset, and every grid bracket of it.

    The bracket inside the fitted range whose t is closest to the paper's (else any), bisected
    on h with the full model.
    """
    found = brackets(m, target)
    if not found:
        return None, found
    fitted = [(i, j) for i, j in found if H_GRID[i] >= 3.0]
    i, j = min(fitted or found, key=lambda ij: abs(T_GRID[ij[1]] - PAPER[1]))
    t = float(T_GRID[j])
    lo, hi = float(H_GRID[i]), float(H_GRID[i + 1])
    f_lo = full_model(lo, t)[1] - target
    mid = 0.5 * (lo + hi)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        value = full_model(mid, t)[1]
        if abs(value - target) <= 2e-4 * target:
            break
        if (value - target) * f_lo <= 0:
            hi = mid
        else:
            lo, f_lo = mid, value - target
    last, _, classes, holds = full_model(mid, t)
    return {
        "h": mid,
        "t": t,
        "reset": last,
        "classes": classes,
        "holds": holds,
        "fitted": finger(mid, t).in_fitted_range,
    }, found


def _batch_field(points):
    designs = [finger(h, t) for h, t in points]
    out = reset_times_batch(DesignBatch.from_designs(designs), PULSE, t_end=T_END)
    classes = out["unit_class"][:, :6]
    return (last_reset(out["reset_time"][:, :6], classes, metastable_only=False), classes)


def change(a, b):
    """Relative change from a to b, against the smaller magnitude floored at 0.05 s."""
    with np.errstate(all="ignore"):
        return np.abs(np.asarray(b) - a) / np.maximum(np.minimum(np.abs(a), np.abs(b)), 0.05)


def smoothness(m, *, levels: int = 6):
    """Neighbour pairs by what changes between them, and a refinement test of the steep ones.

    Pairs with equal classes whose field differs by more than 25 % (of the smaller value, at
    least 0.05 s: monostable resets near 0 do not count as jumps) are bisected ``levels``
    times (keeping the half with the larger jump, all pairs in one batch per level); a pair is
    a discontinuity if the jump over the last 1/64 of the step is still above 10 %, otherwise
    it is steep but continuous (the reset diverges at the bistable edge).
    """
    cls, field = m["classes"], m["field"]
    counts = {"pairs": 0, "class_change": 0, "final_state_change": 0, "steep": 0}
    steep = []
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis] = slice(0, -1)
        b[axis] = slice(1, None)
        a, b = tuple(a), tuple(b)
        same = np.all(cls[a] == cls[b], axis=-1)
        counts["pairs"] += same.size
        counts["class_change"] += int(np.sum(~same))
        counts["final_state_change"] += int(np.sum(m["final"][a] != m["final"][b]))
        rel = change(field[a], field[b])
        flagged = same & m["holds"][a] & np.isfinite(rel) & (rel > 0.25)
        for i, j in zip(*np.nonzero(flagged), strict=True):
            steep.append(
                [
                    (m["h"][a][i, j], m["t"][a][i, j]),
                    (m["h"][b][i, j], m["t"][b][i, j]),
                    field[a][i, j],
                    field[b][i, j],
                ]
            )
    counts["steep"] = len(steep)
    for _ in range(levels):
        if not steep:
            break
        mids = [((p[0] + q[0]) / 2, (p[1] + q[1]) / 2) for p, q, _, _ in steep]
        values, _ = _batch_field(mids)
        for pair, mid, value in zip(steep, mids, values, strict=True):
            p, q, fp, fq = pair
            left, right = change(fp, value), change(value, fq)
            if not np.isfinite(left) or (np.isfinite(right) and right > left):
                pair[0], pair[2] = mid, value
            else:
                pair[1], pair[3] = mid, value
    jumps = []
    for p, q, fp, fq in steep:
        if not np.isfinite(change(fp, fq)) or change(fp, fq) > 0.1:
            jumps.append((p, q, fp, fq, _batch_field([p])[1][0, 4:6]))
    return counts, jumps


def column_text(m) -> str:
    """The minimum of the last reset along h at the paper's t."""
    j = int(np.argmin(np.abs(T_GRID - PAPER[1])))
    column = np.where(m["holds"][:, j], m["last"][:, j], np.nan)
    i = int(np.nanargmin(column))
    return (
        f"- Along h at fixed t the last metastable reset need not be monotone: at t = "
        f"{T_GRID[j]:g} its smallest value is {column[i]:.3f} s, at h = {H_GRID[i]:g} mm "
        "(right panel), so a target below it is out of reach at that t; lower targets "
        "need thicker domes (larger t)."
    )


def order_text(m) -> str:
    """Which tip unit resets last where both are metastable."""
    both = np.all(m["classes"][..., 4:6] == 1, axis=-1) & m["holds"]
    five_last = both & (m["reset"][..., 4] >= m["reset"][..., 5])
    return (
        f"- Where both tip units are metastable ({int(both.sum())} designs), unit 5 resets "
        f"last in {int(five_last.sum())}; so unit 5 sets the scene's default objective "
        "there."
    )


def fitted_band_text(m) -> str:
    """How wide the metastable band is inside the fitted range."""
    ok = m["holds"] & np.isfinite(m["last"]) & (m["h"] >= 3.0)
    if not ok.any():
        return "- No metastable tip unit inside the fitted range."
    cols = [j for j in range(len(T_GRID)) if ok[:, j].any()]
    tops = {T_GRID[j]: H_GRID[ok[:, j]].max() for j in cols}
    j_paper = int(np.argmin(np.abs(T_GRID - PAPER[1])))
    paper = (
        f"; at the paper's t = {T_GRID[j_paper]:g} only h in [3.0, "
        f"{H_GRID[ok[:, j_paper]].max():.2f}] mm"
        if ok[:, j_paper].any()
        else ""
    )
    return (
        f"- Inside the fitted range the band of metastable designs is h from 3.0 mm to "
        f"{tops[T_GRID[cols[0]]]:.2f} mm at t = {T_GRID[cols[0]]:g}, widening to "
        f"{tops[T_GRID[cols[-1]]]:.2f} mm at t = {T_GRID[cols[-1]]:g}{paper}."
    )


def class_regions(m):
    """Share of the grid per class of units 5 and 6, and the classes units 1-4 take."""
    lines = []
    for k in (4, 5):
        values, counts = np.unique(m["classes"][..., k], return_counts=True)
        text = ", ".join(
            f"{CLASS_NAMES[int(v)] or 'never inverted'} {c}"
            for v, c in zip(values, counts, strict=True)
        )
        lines.append(f"- unit {k + 1}: {text} (of {m['classes'][..., k].size})")
    holds = m["holds"]
    lines.append(
        f"- units 1-4 all bistable (the grasp set point holds) on {int(holds.sum())} of "
        f"{holds.size} designs; elsewhere some of them reset (thin domes: low t)"
    )
    return lines


def figure(m, hits, path: Path) -> None:
    """The map, the two tip units' classes and a few columns, as one PNG."""
    fig = Figure(figsize=(17, 4.6), layout="constrained")
    axes = fig.subplots(1, 4)
    h, t = m["h"], m["t"]
    ax = axes[0]
    last = np.ma.masked_invalid(np.where(m["holds"], m["last"], np.nan))
    mesh = ax.pcolormesh(
        h, t, last, norm=LogNorm(vmin=0.05, vmax=10.0), cmap="viridis", shading="nearest"
    )
    fig.colorbar(mesh, ax=ax, label="last metastable unit's reset time (s)")
    field = np.where(m["holds"], m["field"], np.nan)
    cs = ax.contour(h, t, field, levels=list(TARGETS), colors="w", linewidths=0.8)
    ax.clabel(cs, fmt="%g s", fontsize="small")
    ax.contour(h, t, m["holds"].astype(float), levels=[0.5], colors="r", linewidths=1.0)
    for hit in hits.values():
        if hit:
            ax.plot(hit["h"], hit["t"], "r*", markersize=10)
    ax.plot(*PAPER, "ks", markerfacecolor="none", label="paper (3.0, 0.83)")
    ax.axvline(3.0, color="0.4", linestyle="--", linewidth=0.8)
    ax.set_title(
        "last metastable reset (white: none / units 1-4 not held)\n"
        "red line: units 1-4 bistable above it; stars: targets hit",
        fontsize="small",
    )
    ax.legend(fontsize="small", loc="lower right")
    palette = ListedColormap(["0.85", "tab:blue", "tab:green", "tab:orange", "tab:gray"])
    norm = BoundaryNorm([-1.5, -0.5, 0.5, 1.5, 2.5, 3.5], palette.N)
    for ax, k in zip(axes[1:3], (4, 5), strict=True):
        mesh = ax.pcolormesh(h, t, m["classes"][..., k], cmap=palette, norm=norm, shading="nearest")
        ax.contour(h, t, m["holds"].astype(float), levels=[0.5], colors="r", linewidths=1.0)
        bar = fig.colorbar(mesh, ax=ax, ticks=[-1, 0, 1, 2, 3])
        bar.ax.set_yticklabels(["never inv.", "bistable", "metastable", "monostable", "no contact"])
        ax.set_title(f"class of unit {k + 1}", fontsize="small")
    for ax in axes[:3]:
        ax.set_xlabel("H_5 = H_6 (mm)")
        ax.set_ylabel("t (mm)")
    ax = axes[3]
    for n, t_col in enumerate((0.6, 0.7, 0.83, 0.9, 1.0)):
        j = int(np.argmin(np.abs(T_GRID - t_col)))
        for k, style in ((4, "-"), (5, ":")):
            values = np.where(np.isin(m["classes"][:, j, k], (1, 2)), m["reset"][:, j, k], np.nan)
            ax.plot(
                H_GRID, values, style, color=f"C{n}", label=f"t = {T_GRID[j]:g}" if k == 4 else None
            )
    for target in TARGETS:
        ax.axhline(target, color="0.6", linewidth=0.6)
    ax.set_yscale("log")
    ax.set_xlabel("H_5 = H_6 (mm)")
    ax.set_ylabel("reset time (s): unit 5 solid, unit 6 dotted")
    ax.set_title("columns of the map (grey: targets)", fontsize="small")
    ax.legend(fontsize="small")
    fig.savefig(path, dpi=110)


def report(m, hits, reach, counts, jumps, paper, wall_hits) -> str:
    """The markdown report."""
    ok = m["holds"] & np.isfinite(m["last"])
    in_fit = ok & (m["h"] >= 3.0)
    info = machine_info()
    lines = [
        "# Pick-and-place finger: reset times over (H_5 = H_6, t)",
        "",
        "Groundwork for issue 14's pick-and-place scene. The paper's finger (MODEL.md §9: "
        "H_1..H_4 = 4.0, 4.5, 5.0, 5.0; U_sep = 1, U_L = 6, t_lim = 1, E = 26) with "
        "H_5 = H_6 = h and t free, under P0 = 0.7 MPa, tau = 0, 1, 5, 5.1 s, 15 s horizon "
        "(a unit still inverted 9.9 s after the release reads bistable). "
        f"Grid: h = {H_GRID[0]}..{H_GRID[-1]} mm step 0.02 ({len(H_GRID)}), t = "
        f"{T_GRID[0]}..{T_GRID[-1]} mm step 0.01 ({len(T_GRID)}): {m['n']} designs, one "
        f"`reset_times_batch` call (Rodas4, full model), {m['wall']:.1f} s wall on "
        f"{info['cores']} cores ({info['cpu']}; {info['date']}; the machine was shared with "
        "other jobs).",
        "",
        "Reproduce: `PYTHONPATH=. .venv/bin/python scripts/pickplace_reset_map.py` "
        f"(writes this file and `{NAME}.png`).",
        "",
        "![map](" + NAME + ".png)",
        "",
        "## Reachable range",
        "",
        "The scene needs units 1-4 bistable (they hold the grasp set point `111100` while the "
        "tip units reset); the ranges below count only such designs.",
        "",
        f"- Last metastable unit's reset time: {m['last'][ok].min():.3f} to "
        f"{m['last'][ok].max():.3f} s ({int(ok.sum())} of {m['n']} designs have units 1-4 "
        "bistable and a metastable tip unit).",
        (
            f"- Inside the fitted range (h >= 3 mm): {m['last'][in_fit].min():.3f} to "
            f"{m['last'][in_fit].max():.3f} s ({int(in_fit.sum())} designs), all at t >= "
            f"{m['t'][in_fit].min():.2f} mm."
        )
        if in_fit.any()
        else "- No such design inside the fitted range (h >= 3 mm).",
        fitted_band_text(m),
        order_text(m) + " Both reset times grow without bound at the bistable edge "
        "(the ghost of the lost minimum, MODEL.md §4): the upper end of the range is the "
        "horizon's, not the model's; a target of several seconds needs a horizon well beyond it.",
        column_text(m),
        f"- The paper's finger (h = 3.0, t = 0.83): reset times {paper[0]} s (units 5, 6), "
        f"classes {', '.join(paper[1])}.",
        "",
        "## Targets",
        "",
        "For each target, the grid intervals along h where the last tip reset crosses it "
        "(units 1-4 bistable); one of them (inside the fitted range if any, t nearest the "
        "paper's 0.83) bisected on h with `simulate`, the full model, to 0.02 %:",
        "",
        "| target s | crossings on the grid | of them h >= 3 | t range of crossings | h mm | "
        "t mm | last metastable reset s (full model) | rel. error | classes of units 1-6 | "
        "fitted range |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for target, hit in hits.items():
        found = reach[target]
        n_fit = sum(H_GRID[i] >= 3.0 for i, _ in found)
        t_span = (
            f"{min(T_GRID[j] for _, j in found):.2f}-{max(T_GRID[j] for _, j in found):.2f}"
            if found
            else "-"
        )
        if hit is None:
            lines.append(f"| {target} | 0 | 0 | - | - | - | not reachable | | | |")
            continue
        lines.append(
            f"| {target} | {len(found)} | {n_fit} | {t_span} | {hit['h']:.5f} | {hit['t']:.2f} "
            f"| {hit['reset']:.4f} | {abs(hit['reset'] - target) / target:.1e} | "
            f"{', '.join(c or '-' for c in hit['classes'])} | "
            f"{'yes' if hit['fitted'] else 'no'} |"
        )
    lines += [
        "",
        f"Bisection and verification: {wall_hits:.1f} s wall for the four targets "
        "(single simulations, about 15 each).",
        "",
        "## Where the map is smooth",
        "",
        f"- Neighbour pairs on the grid: {counts['pairs']}; pairs where a unit changes class: "
        f"{counts['class_change']}; where the final state changes: "
        f"{counts['final_state_change']}.",
        f"- Pairs with equal classes and units 1-4 bistable whose last tip reset differs by "
        "more than 25 %: "
        f"{counts['steep']}. Each was bisected six times (to 1/64 of a grid step); "
        f"{len(jumps)} still jump by more than 10 % there (true discontinuities, "
        f"{sum(int(j[4][0]) == 1 for j in jumps)} of them with unit 5 metastable"
        + (
            ", listed below); the rest change by less than 10 % over 1/64 of a step: steep "
            "but continuous (the reset diverges at the bistable edge)."
            if jumps
            else "); all change by less than 10 % over 1/64 of a step: steep but continuous (the "
            "reset diverges at the bistable edge)."
        ),
    ]
    for p, q, fp, fq, cls in jumps[:15]:
        names = ", ".join(CLASS_NAMES[int(c)] or "never inverted" for c in cls)
        lines.append(
            f"  - (h, t) = ({p[0]:.4f}, {p[1]:.4f}) -> ({q[0]:.4f}, {q[1]:.4f}): "
            f"{fp:.4g} -> {fq:.4g} s (units 5, 6: {names})"
        )
    lines += [
        *class_boundary_text(),
        "",
        "Classes over the grid:",
        "",
        *class_regions(m),
    ]
    return "\n".join(lines) + "\n"


def class_boundary_text() -> list[str]:
    """What happens across the class boundaries."""
    return [
        "- Across class boundaries the objective jumps: a tip unit turning bistable (reset "
        "`inf`), a unit 6 that no longer inverts (thick, tall domes: it needs more than "
        "0.7 MPa), or units 1-4 losing bistability (thin domes). Within the region where "
        "units 1-4 hold and unit 5 is metastable the map is smooth apart from the "
        "discontinuities above, so a gradient or bracketing method on (h, t) works there.",
    ]


def main() -> int:
    """Compute, plot and write the report."""
    OUT.mkdir(parents=True, exist_ok=True)
    m = compute_map()
    print(f"map: {m['n']} designs in {m['wall']:.1f} s", file=sys.stderr)
    counts, jumps = smoothness(m)
    print(f"smoothness: {counts}, {len(jumps)} jumps", file=sys.stderr)
    start = time.perf_counter()
    hits, reach = {}, {}
    for target in TARGETS:
        hits[target], reach[target] = hit_target(m, target)
        print(f"target {target}: {hits[target]}", file=sys.stderr)
    wall_hits = time.perf_counter() - start
    run = simulate(finger(*PAPER), PULSE, t_end=T_END, n_samples=0)
    paper = ([round(float(v), 4) for v in run.reset_time[4:]], run.unit_class[4:])
    figure(m, hits, OUT / f"{NAME}.png")
    (OUT / f"{NAME}.md").write_text(report(m, hits, reach, counts, jumps, paper, wall_hits))
    return 0


if __name__ == "__main__":
    sys.exit(main())
