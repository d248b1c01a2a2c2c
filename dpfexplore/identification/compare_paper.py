"""The shell model's spring constants beside the paper's closed forms over the paper's box.

Over a grid of the paper's box (``H ∈ [3, 5]``, ``t ∈ [0.5, 1]``, ``r_b = 5``, ``E = 26``,
``ν = 0.35``) every dome's curve is traced (:func:`~dpfexplore.unitcell.unit_cell_curve`), its
table read as ``identify fit`` reads it and the spring law fitted two ways: by the unit's states
(``states_*`` columns, ``identify``'s default, :mod:`dpfexplore.identification.states`: the
inverted rest matched, initial slope and barrier balanced) and by features (the plain columns,
:func:`~dpfexplore.identification.features.fit_features`: ``k_b`` the initial slope, the law's
second minimum at the inverted rest, with that rest's energy). The shell's ``tip_dis`` is its
zero-force inverted apex travel (no contact); ``cell_tip_dis`` that of the dome set in its unit
cell's plate (:func:`~dpfexplore.unitcell.geometry.cell_plate`), the reach the packaged set
takes. The paper's values are
those of its closed forms (:data:`dpfexplore.model.constants_set.DEFAULT`); the class is
bistable ``α < 1/9``, metastable ``α < 1/3``, else monostable (:mod:`dpfexplore.model.constants`).
Neither side is tuned to the other.

:func:`identify_sweep` makes a constants set from a ``unitcell sweep`` directory the same way
(how the packaged ``shell-extended`` was identified). The record and figure
``results/reports/unitcell-vs-paper.{json,png}`` and that set are written by
``scripts/unitcell_vs_paper.py`` (``--help``).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from ..model.constants import ALPHA_BISTABLE, ALPHA_GHOST
from ..model.constants_set import DEFAULT
from ..unitcell.geometry import cell_plate
from ..unitcell.shell import unit_cell_curve
from .curves import read_table
from .features import fit_features
from .identify import DEFAULT_METHOD
from .spring_fit import fit_curve
from .states import fit_states, states_curves_from_frame

__all__ = [
    "PAPER_BOX",
    "classify",
    "compare_grid",
    "compare_unit",
    "identify_sweep",
    "plot_maps",
    "summarise",
]

log = logging.getLogger(__name__)

#: The paper's box and material (MODEL.md §11): H and t ranges (mm), r_b (mm), E (MPa), ν.
PAPER_BOX = {"H": (3.0, 5.0), "t": (0.5, 1.0), "r_b": 5.0, "E": 26.0, "nu": 0.35}


def classify(alpha: float) -> str:
    """``"bistable"`` (``α < 1/9``), ``"metastable"`` (``α < 1/3``), else ``"monostable"``."""
    if not np.isfinite(alpha):
        return "none"
    if alpha < ALPHA_BISTABLE:
        return "bistable"
    return "metastable" if alpha < ALPHA_GHOST else "monostable"


def compare_unit(
    H: float,
    t: float,
    *,
    r_b: float = PAPER_BOX["r_b"],
    E: float = PAPER_BOX["E"],
    nu: float = PAPER_BOX["nu"],
    n_elements: int | None = None,
) -> dict[str, float | str | bool | None]:
    """One dome: the shell's identified constants beside the paper's (module docstring)."""
    run = unit_cell_curve(H, t, r_b, E, nu, n_elements=n_elements)
    cell = unit_cell_curve(H, t, r_b, E, nu, n_elements=n_elements, plate=cell_plate(r_b))
    frame = run.to_frame()
    curve = states_curves_from_frame(frame)[0]
    fit = fit_features(curve)
    states = fit_states(curve)
    least = fit_curve(curve)  # the default method on the same table, for contrast
    paper = DEFAULT.evaluate(H, t, r_b, E)
    k_p, a_p, tip_p = (float(paper[k]) for k in ("k_b", "alpha", "tip_dis"))
    stable_rests = [z for z in run.zero_force_states if z.stable and z.displacement > H]
    saddles = [z for z in run.zero_force_states if z.index == 1]
    row: dict[str, float | str | bool | None] = {
        "H": H,
        "t": t,
        "r_b": r_b,
        "E": E,
        "nu": nu,
        "status": run.status,
        "steps": run.n_steps,
        "folds": int(run.folds.size),
        "first_fold": float(run.folds[0]) if run.folds.size else None,
        "shell_bistable": bool(run.bistable),
        "shell_tip_dis": run.tip_dis,
        "shell_rest_energy": stable_rests[-1].energy if stable_rests else None,
        "shell_saddle_energy": min(z.energy for z in saddles) if saddles else None,
        "shell_initial_stiffness": run.initial_stiffness,
        "k_b": fit.k_b,
        "alpha": fit.alpha,
        "d_law": fit.d,
        "class": classify(fit.alpha),
        "flags": "; ".join(fit.flags),
        "relative_rms": fit.relative_rms,
        "far_kind": "rest" if "far_force" not in fit.features else "ghost",
        "paper_k_b": k_p,
        "paper_alpha": a_p,
        "paper_tip_dis": tip_p,
        "paper_class": classify(a_p),
        "least_squares_k_b": least.k_b,
        "least_squares_alpha": least.alpha,
        "least_squares_d": least.d,
        "least_squares_rms": least.relative_rms,
        "least_squares_ok": least.ok,
    }
    for name, value in fit.features.items():
        row[f"feature_{name}"] = value
    for name, value in fit.residuals.items():
        row[f"residual_{name}"] = value
    row.update(
        {
            "states_k_b": states.k_b,
            "states_alpha": states.alpha,
            "states_class": classify(states.alpha),
            "states_flags": "; ".join(states.flags),
            "states_k_b_ratio": states.k_b / k_p,
            "states_alpha_difference": states.alpha - a_p,
            "states_saddle_energy": states.features.get("saddle_energy"),
            "cell_tip_dis": cell.tip_dis,
            "cell_tip_kind": cell.tip_kind,
            "cell_initial_stiffness": cell.initial_stiffness,
            "cell_tip_relative": (cell.tip_dis / tip_p - 1) if cell.tip_dis is not None else None,
        }
    )
    row["states_class_agrees"] = row["states_class"] == row["paper_class"]
    for name, value in states.residuals.items():
        row[f"states_residual_{name}"] = value
    row["k_b_ratio"] = fit.k_b / k_p
    row["initial_stiffness_ratio"] = run.initial_stiffness / k_p
    row["alpha_difference"] = fit.alpha - a_p
    row["tip_dis_difference"] = (run.tip_dis - tip_p) if run.tip_dis is not None else None
    row["tip_dis_relative"] = (run.tip_dis / tip_p - 1) if run.tip_dis is not None else None
    row["class_agrees"] = row["class"] == row["paper_class"]
    return row


def compare_grid(
    H_values: Sequence[float],
    t_values: Sequence[float],
    *,
    n_elements: int | None = None,
    **material: float,
) -> pd.DataFrame:
    """:func:`compare_unit` on the grid ``H_values × t_values``, one row per dome."""
    rows = []
    for H in H_values:
        for t in t_values:
            rows.append(compare_unit(float(H), float(t), n_elements=n_elements, **material))
            log.info("H = %g, t = %g: done", H, t)
    return pd.DataFrame(rows)


def _span(values: pd.Series) -> dict[str, float]:
    v = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return {}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}


def _rms(values: pd.Series) -> float:
    v = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    return float(np.sqrt(np.nanmean(v**2)))


def _log_rms(values: pd.Series) -> float:
    v = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    return float(np.sqrt(np.nanmean(np.log(v) ** 2)))


def summarise(frame: pd.DataFrame) -> dict:
    """Ratios, differences, class agreement and the features' residuals over the grid."""
    confusion = (
        frame.groupby(["paper_class", "class"]).size().rename("n").reset_index().to_dict("records")
    )
    disagree = frame.loc[~frame["class_agrees"], ["H", "t", "paper_alpha", "alpha"]]
    states_disagree = frame.loc[~frame["states_class_agrees"], ["H", "t", "paper_alpha"]]
    return {
        "units": len(frame),
        "states": {
            "fits_flagged": int((frame["states_flags"] != "").sum()),
            "k_b_ratio_shell_over_paper": _span(frame["states_k_b_ratio"]),
            "k_b_ratio_log_rms": _log_rms(frame["states_k_b_ratio"]),
            "alpha_shell": _span(frame["states_alpha"]),
            "alpha_difference_shell_minus_paper": _span(frame["states_alpha_difference"]),
            "alpha_difference_rms": _rms(frame["states_alpha_difference"]),
            "alpha_correlation": float(frame["states_alpha"].corr(frame["paper_alpha"])),
            "class_agreement": {
                "agree": int(frame["states_class_agrees"].sum()),
                "of": len(frame),
                "disagree_at": states_disagree.to_dict("records"),
            },
            "slope_residual": _span(frame.get("states_residual_slope", pd.Series(dtype=float))),
            "saddle_residual": _span(
                frame.get("states_residual_saddle_energy", pd.Series(dtype=float))
            ),
        },
        "cell_tip": {
            "relative_to_paper": _span(frame["cell_tip_relative"]),
            "kinds": frame["cell_tip_kind"].fillna("none").value_counts().to_dict(),
            "over_H": _span(frame["cell_tip_dis"] / frame["H"]),
        },
        "k_b_ratio_log_rms": _log_rms(frame["k_b_ratio"]),
        "alpha_difference_rms": _rms(frame["alpha_difference"]),
        "fits_flagged": int((frame["flags"] != "").sum()),
        "k_b_ratio_shell_over_paper": _span(frame["k_b_ratio"]),
        "initial_stiffness_over_paper_k_b": _span(frame["initial_stiffness_ratio"]),
        "slope_feature_over_initial_stiffness": _span(
            frame["feature_slope"] / frame["shell_initial_stiffness"]
        ),
        "alpha_shell": _span(frame["alpha"]),
        "alpha_paper": _span(frame["paper_alpha"]),
        "alpha_difference_shell_minus_paper": _span(frame["alpha_difference"]),
        "tip_dis_difference_mm": _span(frame["tip_dis_difference"]),
        "tip_dis_relative": _span(frame["tip_dis_relative"]),
        "tip_dis_over_H_shell": _span(frame["shell_tip_dis"] / frame["H"]),
        "d_law_over_H": _span(frame["d_law"] / frame["H"]),
        "paper_reach_over_H": _span((frame["paper_tip_dis"] - frame["H"]) / frame["H"]),
        "class_agreement": {
            "agree": int(frame["class_agrees"].sum()),
            "of": len(frame),
            "confusion": confusion,
            "disagree_at": disagree.to_dict("records"),
        },
        "unmatched_feature_residuals": {
            name: _span(frame[f"residual_{name}"])
            for name in ("barrier_energy", "peak_force")
            if f"residual_{name}" in frame
        },
        "far_state_against_run": {
            "displacement_relative": _span(
                frame["feature_far_displacement"] / frame["shell_tip_dis"] - 1
            ),
            "energy_relative": _span(frame["feature_far_energy"] / frame["shell_rest_energy"] - 1),
        },
        "relative_rms_up_to_rest": _span(frame["relative_rms"]),
        "least_squares_default": {
            "trusted": int(frame["least_squares_ok"].sum()),
            "alpha": _span(frame["least_squares_alpha"]),
            "d_over_H": _span(frame["least_squares_d"] / frame["H"]),
            "relative_rms": _span(frame["least_squares_rms"]),
        },
    }


def plot_maps(frame: pd.DataFrame, *, recipe: str = "states", fig=None):
    """Stability maps against ``t`` and ``H``: the paper's ``α``, the shell's, ``k_b`` ratio.

    ``recipe``: whose constants are the shell's, ``"states"`` (``identify``'s default) or
    ``"features"``. Returns the figure (no file I/O).
    """
    if recipe not in ("states", "features"):
        raise ValueError(f"recipe={recipe!r}: must be 'states' or 'features'")
    prefix = "states_" if recipe == "states" else ""
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm

    fig = fig or plt.figure(figsize=(13.5, 4.2), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    H_values = np.sort(frame["H"].unique())
    t_values = np.sort(frame["t"].unique())
    tt, hh = np.meshgrid(np.linspace(*PAPER_BOX["t"], 121), np.linspace(*PAPER_BOX["H"], 121))
    r_b, E = frame["r_b"].iloc[0], frame["E"].iloc[0]
    paper_fine = DEFAULT.evaluate(hh, tt, r_b, E)["alpha"]
    levels = np.linspace(0.0, 0.18, 19)  # the paper's α reaches 0.173 in its box
    norm = BoundaryNorm(levels, 256)
    mark = {"bistable": "o", "metastable": "^", "monostable": "s", "none": "x"}

    def grid(column):
        return frame.pivot(index="H", columns="t", values=column).loc[H_values, t_values]

    def classes(ax, column):
        for kind, marker in mark.items():
            on = frame[column] == kind
            if on.any():
                ax.scatter(
                    frame.loc[on, "t"], frame.loc[on, "H"], marker=marker, s=22,
                    facecolor="none", edgecolor="k", linewidth=0.8, label=kind,
                )  # fmt: skip

    image = axes[0].contourf(tt, hh, paper_fine, levels=levels, cmap="viridis", norm=norm)
    axes[0].contour(tt, hh, paper_fine, levels=[ALPHA_BISTABLE], colors="w", linewidths=1.5)
    classes(axes[0], "paper_class")
    axes[0].set_title("paper's closed form: α (white: α = 1/9)")
    shell_alpha = grid(f"{prefix}alpha").to_numpy()
    axes[1].contourf(t_values, H_values, shell_alpha, levels=levels, cmap="viridis", norm=norm)
    if np.nanmin(shell_alpha) < ALPHA_BISTABLE < np.nanmax(shell_alpha):
        axes[1].contour(
            t_values, H_values, shell_alpha, levels=[ALPHA_BISTABLE], colors="w", linewidths=1.5
        )
    classes(axes[1], f"{prefix}class")
    axes[1].set_title(f"shell, {recipe} fit: α (markers: class)")
    fig.colorbar(image, ax=axes[:2], label="α", shrink=0.9)
    ratio = grid(f"{prefix}k_b_ratio").to_numpy()
    rmap = axes[2].contourf(t_values, H_values, ratio, levels=12, cmap="magma")
    fig.colorbar(rmap, ax=axes[2], label="k_b shell / k_b paper")
    axes[2].set_title(f"k_b: shell ({recipe} fit) / paper")
    for ax in axes:
        ax.set_xlabel("t (mm)")
        ax.set_xlim(PAPER_BOX["t"][0] - 0.02, PAPER_BOX["t"][1] + 0.02)
        ax.set_ylim(PAPER_BOX["H"][0] - 0.05, PAPER_BOX["H"][1] + 0.05)
    axes[0].set_ylabel("H (mm)")
    axes[0].legend(loc="upper right", fontsize=7)
    return fig


def identify_sweep(directory: str | Path, *, name: str, method: str = DEFAULT_METHOD):
    """A constants set from a ``unitcell sweep`` directory, by ``identify``'s per-curve ``method``.

    ``k̂`` and ``α`` come from every trusted fit (monostable shells included: their ghost gives
    a metastable ``α``); ``tip_dis`` exists for the domes with a stable inverted rest and for
    the monostable ones with a ghost (its travel: the rest merges into it at the bistable edge,
    :mod:`dpfexplore.unitcell.path`), in the sweep's ``tip`` model (the cap's own, or the dome
    set in its unit cell's plate), so its closed form is selected on those (the sweep's
    ``curves.parquet`` leaves the column out when one dome lacks it), and the set's domain is
    theirs. Flagged fits are left out and counted in the notes.

    Returns
    -------
    Identification
    """
    from .identify import Identification, identify

    directory = Path(directory)
    table = read_table(directory / "curves.parquet")
    designs = read_table(directory / "designs.parquet")
    curves = states_curves_from_frame(table)
    main_fit = identify(curves, name=name, method=method, allow_flagged=True)
    # the sweep names curve i "d{i:06d}" (dpfexplore.unitcell.sweep)
    tips = {f"d{int(i):06d}": v for i, v in zip(designs["design"], designs["tip_dis"], strict=True)}
    if not set(tips) >= set(table["curve"].astype(str)):
        raise ValueError(f"{directory}: curves.parquet and designs.parquet do not match")
    # a designs.parquet without tip_kind holds rests only
    kind = (
        designs["tip_kind"]
        if "tip_kind" in designs
        else designs["tip_dis"].notna().map({True: "rest", False: ""})
    )
    kinds = dict(zip(designs["design"], kind, strict=True))
    n_ghost = sum(kinds[int(c[1:])] == "ghost" for c in table["curve"].astype(str).unique())
    with_tip = table[table["curve"].astype(str).map(tips).notna()]
    with_tip = with_tip.assign(tip_dis=with_tip["curve"].astype(str).map(tips))
    tip_fit = identify(
        states_curves_from_frame(with_tip), name=name, method=method, allow_flagged=True
    )
    selections = {**main_fit.selections, "tip_ratio": tip_fit.selections["tip_ratio"]}
    flagged = sum(not f.ok for f in main_fit.fits)
    where = (
        "of the dome set in its unit cell's plate (the sweep's tip = 'cell')"
        if "cap_tip_dis" in designs
        else "of the pinned cap"
    )
    notes = [
        f"k_hat, alpha: {len(curves) - flagged} of {len(curves)} curves ({method} fit; "
        f"{flagged} flagged and left out)",
        f"tip_ratio: the {with_tip['curve'].nunique()} curves with a tip_dis {where} "
        f"({n_ghost} of them monostable, by their ghost's travel); the domain is theirs (a dome "
        "with neither an inverted rest nor a least force past H has no tip_dis and lies "
        "outside it)",
    ]
    provenance = {
        **main_fit.constants.provenance,
        "notes": notes,
        "sweep": str(directory),
        "tip_ratio_data_sha256": tip_fit.constants.provenance["data_sha256"],
    }
    # the domain: where the shell gives a tip_dis (an inverted rest or a ghost)
    constants = dataclasses.replace(
        main_fit.constants,
        tip_ratio=selections["tip_ratio"].form,
        provenance=provenance,
        domain={**main_fit.constants.domain, **tip_fit.constants.domain},
        hull=tip_fit.constants.hull,
    )
    constants.check()
    return Identification(constants, main_fit.fits, selections, main_fit.alpha_spread_over_E, notes)
