"""Why the unit-cell route's constants missed the paper's: each cause measured over its box.

The paper's constants came from FE of the same unit cell (MODEL.md §11); the shell's differ.
Four candidates, each measured on a grid of the paper's box (``H ∈ [3, 5]``, ``t ∈ [0.5, 1]``,
``r_b = 5``, ``E = 26``, ``ν = 0.35``) against the paper's closed forms (the default set): the
``k_b`` ratio, the ``α`` difference, the ``tip_dis`` ratio and the class (``α < 1/9``):

* **The per-curve fit.** The quartic law (MODEL.md §4, §11: linear in ``a2, a3, a4``, so the
  least squares are linear and the paper's nonlinear least squares reach the same optimum when
  no bound binds) fitted to four curves a folded path defines: the lower envelope of its stable
  branches up to the inverted rest (``envelope``) and on to the traced travel (``full``), the
  first branch up to its fold (``to_fold``), and the path a displacement-controlled run with
  inertia follows, the first branch to the fold, then the jump onto the stable inverted branch
  and along it to the rest (``jump``); each unweighted (the energy on a uniform grid of
  travel), weighted by energy and force together (each scaled by its RMS), and relative (each
  energy point by its own size). Beside them the laws by features: the initial slope with the
  inverted rest (:mod:`dpfexplore.identification.features`), the barrier with the rest
  (``barrier``: the free dome's saddle energy matched, the slope left free) and both balanced
  (:mod:`dpfexplore.identification.states`, ``identify``'s default), with the balance's
  weights moved 2:1 either way to show how much they matter.
* **The reach.** The inverted apex travel of the pinned cap, of the cap set in its unit cell's
  plate (the square face as an annulus, :mod:`dpfexplore.unitcell.geometry`; the
  area-equivalent and the inscribed radius, the edge pinned and clamped), and the two-unit run
  (:func:`~dpfexplore.unitcell.contact.two_unit_rest`) at the gap of a finger (``U_sep = 1``,
  ``t_ch = 1``): the neighbour's wall rigid, or giving way as the finger's hinge does (the two
  torsion springs of MODEL.md §3 at the limiting layer, lever ``h``: ``k_wall = 2 k_t / h²``,
  ``t_lim = 1.5``).
* **The edge.** The same fits on the cap set in its plate, pinned and clamped.
* **Shear** is not computed here (the shell is shear-rigid): the axisymmetric solid of
  :mod:`dpfexplore.unitcell.solid_check` measures it (``docs/guide/unitcell-crosscheck.md``).

The reach models are :mod:`dpfexplore.unitcell.reach`'s. :func:`run_grid` computes every row;
``scripts/unitcell_causes.py`` writes the record ``results/reports/unitcell-causes.json``::

    .venv/bin/python scripts/unitcell_causes.py  # 7 × 6 grid: 5-20 minutes on one core
"""

from __future__ import annotations

import logging
import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import minimize_scalar

from ..model.closed_form import ClosedForm
from ..model.constants_set import DEFAULT, ConstantsSet
from ..unitcell.reach import reach_variants
from ..unitcell.shell import UnitCellRun
from .compare_paper import PAPER_BOX, classify
from .features import curve_features, fit_features
from .states import _curve_barrier, _law, _law_barrier, fit_states, states_curves_from_frame

__all__ = [
    "FINGER_CASES",
    "box_set",
    "compact_units",
    "curve_definitions",
    "fit_recipes",
    "least_squares_quartic",
    "run_grid",
    "summarise",
    "unit_rows",
]

log = logging.getLogger(__name__)

#: The curve definitions and weightings of the least-squares recipes.
DATA = ("envelope", "full", "to_fold", "jump")
WEIGHTS = ("unweighted", "energy+force", "relative")
#: Grid points of each curve definition.
POINTS = 600


def _stable_pieces(run: UnitCellRun):
    """The path's stretches stable under displacement control, each monotone in the travel."""
    out = []
    key = run.branch * 2 + (~run.stable)
    start = 0
    for i in range(1, run.n_steps + 1):
        if i == run.n_steps or key[i] != key[start]:
            if run.stable[start] and i - start >= 2:
                x, e, f = (a[start:i] for a in (run.displacement, run.energy, run.force))
                order = np.argsort(x)
                x, e, f = x[order], e[order], f[order]
                keep = np.concatenate([[True], np.diff(x) > 0])
                out.append((x[keep], e[keep], f[keep]))
            start = i
    return out


def _on(piece, grid):
    """A piece's energy and force on ``grid`` (inf and nan outside it), cubic Hermite."""
    x, e, f = piece
    energy, force = np.full(grid.shape, np.inf), np.full(grid.shape, np.nan)
    inside = (grid >= x[0]) & (grid <= x[-1])
    spline = CubicHermiteSpline(x, e, f)
    energy[inside], force[inside] = spline(grid[inside]), spline.derivative()(grid[inside])
    return energy, force


def _envelope(pieces, grid):
    energy, force = np.full(grid.shape, np.inf), np.full(grid.shape, np.nan)
    for piece in pieces:
        e, f = _on(piece, grid)
        lower = e < energy
        energy[lower], force[lower] = e[lower], f[lower]
    keep = np.isfinite(energy)
    return grid[keep], energy[keep], force[keep]


def curve_definitions(run: UnitCellRun) -> dict[str, tuple]:
    """The curves of the least-squares recipes (module docstring): ``(x, energy, force)``."""
    pieces = _stable_pieces(run)
    x_far = run.tip_dis
    out = {
        "envelope": _envelope(pieces, np.linspace(0.0, x_far, POINTS)),
        "full": _envelope(pieces, np.linspace(0.0, run.displacement.max(), POINTS)),
    }
    first, fold = pieces[0], pieces[0][0][-1]
    later = [p for p in pieces[1:] if p[0][0] <= x_far <= p[0][-1]]
    if run.folds.size and fold < x_far and later:
        grid = np.linspace(0.0, fold, POINTS)
        out["to_fold"] = (grid, *_on(first, grid))
        inverted = min(later, key=lambda p: _on(p, np.array([x_far]))[0][0])
        grid = np.linspace(0.0, x_far, POINTS)
        (e1, f1), (e2, f2) = _on(first, grid), _on(inverted, grid)
        before = grid <= fold
        energy, force = np.where(before, e1, e2), np.where(before, f1, f2)
        keep = np.isfinite(energy)
        out["jump"] = (grid[keep], energy[keep], force[keep])
    else:  # no fold before the rest: every definition is the path up to it
        out["to_fold"] = out["jump"] = out["envelope"]
    return out


def least_squares_quartic(x, energy, force, weight: str) -> tuple[float, float]:
    """``(k_b, α)`` of the quartic least-squared on a curve; α NaN if it does not snap."""
    A_e = np.column_stack([x**2, x**3, x**4])
    A_f = np.column_stack([2 * x, 3 * x**2, 4 * x**3])
    if weight == "unweighted":
        A, b = A_e, energy
    elif weight == "energy+force":
        se, sf = np.sqrt(np.mean(energy**2)), np.sqrt(np.mean(force**2))
        A, b = np.vstack([A_e / se, A_f / sf]), np.concatenate([energy / se, force / sf])
    elif weight == "relative":
        w = 1.0 / np.maximum(np.abs(energy), 0.02 * np.abs(energy).max())
        A, b = A_e * w[:, None], energy * w
    else:
        raise ValueError(f"weight={weight!r}: must be one of {', '.join(WEIGHTS)}")
    a2, a3, a4 = np.linalg.lstsq(A, b, rcond=None)[0]
    alpha = 1 - a3 * a3 / (4 * a2 * a4) if a2 > 0 and a4 > 0 and a3 < 0 else math.nan
    return float(2 * a2), float(alpha)


def fit_recipes(run: UnitCellRun) -> dict[str, tuple[float, float]]:
    """Every recipe's ``(k_b, α)`` on one run (module docstring); a dome needs a far state."""
    out = {}
    if run.tip_dis is None:
        return out
    for data, (x, energy, force) in curve_definitions(run).items():
        for weight in WEIGHTS:
            out[f"{data}, {weight}"] = least_squares_quartic(x, energy, force, weight)
    (curve,) = states_curves_from_frame(run.to_frame())
    for name, fit in (("features (slope)", fit_features(curve)), ("states", fit_states(curve))):
        out[name] = (fit.k_b, fit.alpha)
    for name, weights in (("barrier", (0.0, 1.0)), ("states 2:1", (2.0, 1.0))):
        fit = _weighted_states(curve, weights)
        out[name] = (fit.k_b, fit.alpha) if fit is not None else (math.nan, math.nan)
    fit = _weighted_states(curve, (1.0, 2.0))
    out["states 1:2"] = (fit.k_b, fit.alpha) if fit is not None else (math.nan, math.nan)
    return out


def _weighted_states(curve, weights):
    """The states law with other weights on (slope, barrier); None without a barrier."""
    feats = curve_features(curve)
    if feats is None or feats.far_kind != "rest":
        return None
    x, e = feats.far_displacement, feats.far_energy
    saddle = _curve_barrier(curve, x, e)
    if saddle is None:
        return None
    floor = np.log(12.0 * e / x**2)

    def cost(log_k):
        k_b, alpha, d = _law(float(np.exp(log_k)), x, e)
        return (
            weights[0] * np.log(k_b / feats.slope) ** 2
            + weights[1] * np.log(_law_barrier(k_b, alpha, d) / saddle) ** 2
        )

    best = minimize_scalar(cost, bounds=(floor + 1e-9, floor + np.log(1e4)), method="bounded")
    k_b, alpha, _ = _law(float(np.exp(best.x)), x, e)
    return SimpleNamespace(k_b=k_b, alpha=alpha)


def unit_rows(H: float, t: float, *, n_elements: int | None = None) -> list[dict]:
    """Every recipe and tip model of one dome, one row each, beside the paper's values."""
    paper = DEFAULT.evaluate(H, t, PAPER_BOX["r_b"], PAPER_BOX["E"])
    k_p, a_p, tip_p = (float(paper[k]) for k in ("k_b", "alpha", "tip_dis"))
    base = {"H": H, "t": t, "paper_k_b": k_p, "paper_alpha": a_p, "paper_tip_dis": tip_p}
    rows = []
    reach = reach_variants(H, t, n_elements=n_elements)
    for model, entry in reach.items():
        run = entry.pop("run", None)
        tip = entry["tip_dis"]
        row = {**base, "cause": "reach", "model": model, **entry}
        row["tip_ratio"] = tip / tip_p if tip is not None else math.nan
        if run is not None:
            row["initial_stiffness"] = run.initial_stiffness
        rows.append(row)
        if run is None:
            continue
        cause = "fit" if model == "cap pinned" else "edge"
        recipes = fit_recipes(run)
        if cause == "edge":  # the plates by the default recipe and the slope alone
            recipes = {k: v for k, v in recipes.items() if k in ("states", "features (slope)")}
        for recipe, (k_b, alpha) in recipes.items():
            rows.append(
                {
                    **base,
                    "cause": cause,
                    "model": model,
                    "recipe": recipe,
                    "k_b": k_b,
                    "alpha": alpha,
                    "k_b_ratio": k_b / k_p,
                    "alpha_difference": alpha - a_p,
                    "class": classify(alpha),
                    "paper_class": classify(a_p),
                }
            )
    return rows


def _table(rows: pd.DataFrame, by: list[str]) -> list[dict]:
    """Per group: k_b ratio span and log-RMS, α span, RMS difference and correlation, classes."""
    out = []
    for key, group in rows.groupby(by, sort=False):
        ratio = group["k_b_ratio"].to_numpy(dtype=float)
        alpha = group["alpha"].to_numpy(dtype=float)
        valid = np.isfinite(alpha) & (alpha > 0) & (alpha < 1) & (ratio > 0)
        entry = dict(zip(by, key if isinstance(key, tuple) else (key,), strict=True))
        entry["units"] = len(group)
        entry["valid"] = int(valid.sum())
        if valid.any():
            r, a = ratio[valid], alpha[valid]
            diff = a - group["paper_alpha"].to_numpy(dtype=float)[valid]
            entry.update(
                k_b_ratio=[float(r.min()), float(np.median(r)), float(r.max())],
                k_b_log_rms=float(np.sqrt(np.mean(np.log(r) ** 2))),
                alpha=[float(a.min()), float(np.median(a)), float(a.max())],
                alpha_rms_difference=float(np.sqrt(np.mean(diff**2))),
                alpha_correlation=float(
                    np.corrcoef(a, group["paper_alpha"].to_numpy(dtype=float)[valid])[0, 1]
                )
                if valid.sum() > 2
                else math.nan,
                classes_agree=int((group["class"] == group["paper_class"]).to_numpy()[valid].sum()),
            )
        out.append(entry)
    return out


def summarise(frame: pd.DataFrame) -> dict:
    """The tables of the record: fit recipes, plates, tip models."""
    fits = frame[frame["cause"] == "fit"]
    edges = frame[frame["cause"].isin(["fit", "edge"]) & frame["recipe"].isin(["states"])]
    reach = frame[frame["cause"] == "reach"]
    tips = []
    for model, group in reach.groupby("model", sort=False):
        ratio = group["tip_ratio"].to_numpy(dtype=float)
        kinds = group["tip_kind"].fillna("none").value_counts().to_dict()
        ok = np.isfinite(ratio)
        entry = {"model": model, "units": len(group), "kinds": kinds}
        if ok.any():
            entry["tip_ratio"] = [
                float(ratio[ok].min()),
                float(np.median(ratio[ok])),
                float(ratio[ok].max()),
            ]
            entry["tip_ratio_rms_error"] = float(np.sqrt(np.mean((ratio[ok] - 1) ** 2)))
        if "initial_stiffness" in group and group["initial_stiffness"].notna().any():
            stiffness = group["initial_stiffness"].to_numpy(dtype=float) / group["paper_k_b"]
            entry["initial_stiffness_over_paper_k_b"] = [
                float(np.nanmin(stiffness)),
                float(np.nanmedian(stiffness)),
                float(np.nanmax(stiffness)),
            ]
        tips.append(entry)
    return {
        "fit_recipes": _table(fits, ["recipe"]),
        "plates_by_states": _table(edges, ["model"]),
        "tip_models": tips,
    }


def compact_units(frame: pd.DataFrame) -> dict[str, dict]:
    """The record's per-dome values, to 6 significant digits.

    Per dome ``"H, t"``: the paper's ``[k_b, α, tip_dis]``, each plate and recipe's
    ``[k_b, α]`` and each tip model's ``[tip_dis, kind]``.
    """

    def g(value):
        return None if value is None or not np.isfinite(value) else float(f"{value:.6g}")

    out: dict[str, dict] = {}
    for (H, t), group in frame.groupby(["H", "t"], sort=False):
        first = group.iloc[0]
        entry = {
            "paper": [g(first["paper_k_b"]), g(first["paper_alpha"]), g(first["paper_tip_dis"])]
        }
        for _, row in group.iterrows():
            if row["cause"] == "reach":
                kind = row["tip_kind"] if isinstance(row["tip_kind"], str) else None
                tip = row["tip_dis"] if row["tip_dis"] is not None else math.nan
                entry[f"tip: {row['model']}"] = [g(float(tip)), kind]
            else:
                entry[f"{row['model']}: {row['recipe']}"] = [g(row["k_b"]), g(row["alpha"])]
        out[f"{H:.6g}, {t:.6g}"] = entry
    return out


#: The per-dome constants put on the printed fingers: (label, recipe or None for the paper's
#: k_b and α, tip model or None for the paper's tip_dis).
FINGER_CASES = (
    ("paper's k_b, α; cap's tip", None, "cap pinned"),
    ("paper's k_b, α; cell's tip", None, "square pinned"),
    ("features; cap's tip", "cap pinned: features (slope)", "cap pinned"),
    ("features; cell's tip", "cap pinned: features (slope)", "square pinned"),
    ("full, energy+force; cell's tip", "cap pinned: full, energy+force", "square pinned"),
    ("to fold, relative; cell's tip", "cap pinned: to_fold, relative", "square pinned"),
    ("barrier; cell's tip", "cap pinned: barrier", "square pinned"),
    ("states; cap's tip", "cap pinned: states", "cap pinned"),
    ("states; cell's tip", "cap pinned: states", "square pinned"),
    ("states; hinge two-unit tip", "cap pinned: states", "two-unit, hinge"),
    ("states 2:1; cell's tip", "cap pinned: states 2:1", "square pinned"),
    ("states 1:2; cell's tip", "cap pinned: states 1:2", "square pinned"),
    ("square plate's states; its tip", "square pinned: states", "square pinned"),
)


def box_set(units: dict[str, dict], name: str, recipe: str | None, tip: str | None):
    """A constants set from the record's per-dome values over the paper's box.

    Each form a full cubic in ``π1 = t/H``, ``π3 = H/R`` (16 terms) least-squared on the grid's
    domes; ``recipe`` (a ``"plate: recipe"`` key of :func:`compact_units`) gives ``k_b`` and
    ``α``, ``tip`` (a tip model) ``tip_dis``; None keeps the paper's form. The domain is the
    paper's box. Raises :class:`~dpfexplore.model.constants_set.ConstantsSetError` when the set
    is unphysical there (a recipe whose ``α`` leaves ``(0, 1)``).
    """
    exponents = tuple((a, b) for a in range(4) for b in range(4))
    keys = list(units)
    H = np.array([float(k.split(",")[0]) for k in keys])
    t = np.array([float(k.split(",")[1]) for k in keys])
    r_b, E = PAPER_BOX["r_b"], PAPER_BOX["E"]
    R = (H**2 + r_b**2) / (2 * H)
    library = np.column_stack([(t / H) ** a * (H / R) ** b for a, b in exponents])

    def form(values):
        values = np.asarray(values, dtype=float)
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{name}: a dome without a value")
        coefficients = np.linalg.lstsq(library, values, rcond=None)[0]
        return ClosedForm(exponents, tuple(float(c) for c in coefficients))

    def column(key, i):
        return [np.nan if units[k][key][i] is None else units[k][key][i] for k in keys]

    k_hat = DEFAULT.k_hat if recipe is None else form(np.array(column(recipe, 0)) * R / (E * t * t))
    alpha = DEFAULT.alpha if recipe is None else form(column(recipe, 1))
    tip_ratio = DEFAULT.tip_ratio if tip is None else form(np.array(column(f"tip: {tip}", 0)) / H)
    constants = ConstantsSet(
        name=name,
        k_hat=k_hat,
        alpha=alpha,
        tip_ratio=tip_ratio,
        domain={"H": PAPER_BOX["H"], "t": PAPER_BOX["t"], "r_b": (r_b, r_b), "E": (5.0, 40.0)},
        provenance={"method": f"dpfexplore.identification.causes.box_set: {recipe}; tip {tip}"},
    )
    constants.check()
    return constants


def run_grid(n_H: int = 7, n_t: int = 6, *, n_elements: int | None = None) -> pd.DataFrame:
    """Every dome's rows (:func:`unit_rows`) on an ``n_H × n_t`` grid of the paper's box."""
    rows = []
    for H in np.linspace(*PAPER_BOX["H"], n_H):
        for t in np.linspace(*PAPER_BOX["t"], n_t):
            rows.extend(unit_rows(float(H), float(t), n_elements=n_elements))
            log.info("H = %g, t = %g: done", H, t)
    return pd.DataFrame(rows)
