"""The dome spring law matched to features of a curve, not least-squared over its path.

A shell's path (``dpfexplore.unitcell``) folds, and its energy rises almost to the inverted
state before it drops (the saddle of a free dome sits near ``1.75 H``, the inverted rest near
``2.03 H``): no quartic describes the whole path, and a least-squares quartic trades everything
for everything (MODEL.md §11; ``docs/guide/unitcell.md``). This fit instead makes the law
``E_NL = a2 x² + a3 x³ + a4 x⁴`` (MODEL.md §4, ``x`` the apex travel from the undeformed dome)
reproduce three features of the curve exactly:

1. the **initial slope** ``k_b = F'(0) = 2 a2``, from a joint energy-and-force quartic fit on
   ``x ≤ w · x_far``, ``w`` the largest of :data:`WINDOWS` whose slope agrees with every
   smaller window's (Lepski's rule: a noisy curve gets a wide window, a shell that softens
   early a narrow one); on a folded curve, on its first branch's own points
   (:class:`PathCurve`; the envelope's linear interpolation biases the slope);
2. the **far state** ``x_far``: the stable zero-force state beyond the barrier (the inverted
   rest, where ``F = 0`` and ``F' > 0``) when the curve has one; otherwise the ghost of the lost
   minimum, where the force is least (``F' = 0``), as in a metastable unit;
3. the **far state's energy** ``E_far`` (inverted rest) or force ``F_far`` (ghost).

Given ``a2``, conditions 2-3 are linear in ``(a3, a4)``: with ``e2 = a2 x²``, at an inverted
rest ``a3 x³ = 4 E_far − 2 e2`` and ``a4 x⁴ = e2 − 3 E_far``; at a ghost ``F'(x) = 0`` and
``F(x) = F_far``, a 2 × 2 linear system. Then ``k_b = 2 a2``,
``d = −a3/(2 a4)``, ``α = 1 − a3²/(4 a2 a4)``.

Why the far state's energy and not the barrier energy or the peak force: the inverted rest is
an equilibrium with no apex load, so its travel and energy do not depend on how the run was
controlled (apex displacement, arclength or force), on which branch the path jumped by, or on a
fit range; it is what the lattice's second minimum stands for (``E_NL(d) = ½ k_b d² α``). The
shell's barrier (a free dome's saddle near ``1.75 H``) and its first-branch peak force (near the
fold) lie far above what any quartic with the shell's initial slope and inverted travel can
reach: with ``k_b`` and ``x_far`` fixed, the quartic's barrier energy is largest at
``α = 1/9``, where barrier and rest merge at ``E_far = k_b x_far²/12``. They are therefore
reported as residuals of the matched law (how much of the curve it does not describe), not
matched. A rest the quartic cannot carry (a force that only just touches zero: ``α ≈ 1/9``, or
noise) is replaced by the ghost it is near.

The fit is flagged when the curve has no far state, when the features give no snapping spring
(``a2, a4 > 0 > a3`` fails) or when the matched law does not have the far state as its own
(an inverted rest that is its barrier). ``relative_rms`` is the law against the curve's energy
up to the far state, over the RMS of that energy: reported, not a flag (the law claims the
features, not the path).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .curves import CurveError, UnitCellCurve, curves_from_frame, read_curve_table
from .spring_fit import CurveFit, spring_energy, spring_force

__all__ = [
    "WINDOWS",
    "CurveFeatures",
    "FeatureFit",
    "PathCurve",
    "curve_features",
    "feature_curves_from_frame",
    "fit_features",
    "quartic_from_features",
    "read_feature_curves",
]

#: Windows (fractions of the far state's travel) on which the initial slope is fitted; the
#: largest whose slope agrees with every smaller one's within ``AGREE`` sigmas is used.
WINDOWS = (0.05, 0.1, 0.2, 0.3, 0.5)
#: Sigmas within which two windows' slopes agree (Lepski's rule).
AGREE = 3.0
#: Fewest points a slope window holds.
MIN_WINDOW_POINTS = 6
#: Half-width of the local polynomial around the far state, as a fraction of its travel.
LOCAL = 0.06


@dataclass(frozen=True)
class PathCurve(UnitCellCurve):
    """A checked curve that also keeps its first branch as the table gave it.

    A folded curve's :class:`~.curves.UnitCellCurve` is the lower energy envelope on a grid,
    interpolated linearly between the path's points: right for the far state (a minimum), but
    biased at the start, where a quadratic is interpolated linearly between coarse points
    (+5 % in the slope on the shell curves). The slope is taken from the first branch's own
    points and forces instead.

    Attributes
    ----------
    start_displacement, start_energy : ndarray, mm and N·mm
        The points of the branch that starts at the smallest displacement, in increasing order.
    start_force : ndarray or None, N
    """

    start_displacement: NDArray | None = None
    start_energy: NDArray | None = None
    start_force: NDArray | None = None


def feature_curves_from_frame(frame: pd.DataFrame) -> list[PathCurve]:
    """The curves of a table, checked as by :func:`~.curves.curves_from_frame`.

    Each folded curve also keeps its first branch, for the initial slope.
    """
    checked = curves_from_frame(frame)
    out = []
    for curve, (_, rows) in zip(checked, frame.groupby("curve", sort=False), strict=True):
        extra = {}
        if curve.folded:
            rows = rows.reset_index(drop=True)
            first = (
                rows["branch"].to_numpy()
                == rows["branch"].iloc[int(np.argmin(rows["displacement"].to_numpy()))]
            )
            x = rows["displacement"].to_numpy(dtype=float)[first]
            order = np.argsort(x, kind="stable")
            extra["start_displacement"] = np.maximum(x[order], 0.0)
            if "energy" in rows:
                extra["start_energy"] = rows["energy"].to_numpy(dtype=float)[first][order]
            if "force" in rows:
                extra["start_force"] = rows["force"].to_numpy(dtype=float)[first][order]
        values = {f.name: getattr(curve, f.name) for f in fields(UnitCellCurve)}
        out.append(PathCurve(**values, **extra))
    return out


def read_feature_curves(path: str | Path) -> list[PathCurve]:
    """Read and check a table as :func:`~.curves.read_curves` does, first branches kept."""
    frame = read_curve_table(path)  # the checks and their one-line errors
    try:
        return feature_curves_from_frame(frame)
    except CurveError as exc:
        raise CurveError(f"{path}: {exc}") from None


@dataclass(frozen=True)
class CurveFeatures:
    """Features of one curve.

    Attributes
    ----------
    slope : float, N/mm
        Initial slope of the force, ``F'(0)``.
    slope_std : float, N/mm
        Its one-sigma uncertainty from the polynomial fit's residual.
    slope_window : float
        The window it was fitted on, as a fraction of ``far_displacement``.
    far_kind : str
        ``"rest"`` (a stable zero-force state beyond the barrier) or ``"ghost"`` (the force's
        least value beyond its peak, no zero).
    far_displacement : float, mm
    far_energy : float, N·mm
    far_force : float, N
        0 for a rest.
    barrier_energy : float, N·mm
        Largest energy of the curve before the far state (on a folded path's envelope: where
        the first and the inverted branch cross).
    peak_force : float or None, N
        Largest force before the far state (None without a force column).
    """

    slope: float
    slope_std: float
    slope_window: float
    far_kind: str
    far_displacement: float
    far_energy: float
    far_force: float
    barrier_energy: float
    peak_force: float | None


@dataclass(frozen=True)
class FeatureFit(CurveFit):
    """A :class:`~.spring_fit.CurveFit` by features, with the features and their residuals.

    Attributes
    ----------
    features : dict
        Feature name -> value on the curve.
    law : dict
        Feature name -> value of the matched law (equal to ``features`` for the matched ones).
    """

    features: dict[str, float] = field(default_factory=dict)
    law: dict[str, float] = field(default_factory=dict)

    @property
    def residuals(self) -> dict[str, float]:
        """Feature name -> ``(law − curve) / abs(curve)`` (0 up to round-off for matched ones)."""
        return {
            k: (self.law[k] - v) / abs(v) if v else float("nan")
            for k, v in self.features.items()
            if k in self.law
        }


def _local_poly(x: NDArray, energy: NDArray, force: NDArray | None, centre: float, half: float):
    """Quartic in ``x − centre`` fitted to the energy (and its derivative to the force) nearby."""
    on = np.abs(x - centre) <= half
    if on.sum() < 5:  # widen to the nearest points
        on = np.zeros(x.size, bool)
        on[np.argsort(np.abs(x - centre))[:7]] = True
    s = x[on] - centre
    rows = [np.column_stack([np.ones_like(s), s, s**2, s**3, s**4])]
    data = [energy[on]]
    if force is not None:
        scale = half or 1.0
        rows.append(np.column_stack([0 * s, np.ones_like(s), 2 * s, 3 * s**2, 4 * s**3]) * scale)
        data.append(force[on] * scale)
    coef, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(data), rcond=None)
    return np.polynomial.Polynomial(coef)


def _far_state(x: NDArray, energy: NDArray, force: NDArray | None, ghost: bool = False):
    """Crude location and kind of the far state.

    The first stable zero of the force beyond its peak and the barrier, else (or with
    ``ghost``) the force's least value beyond its peak.
    """
    slope = force if force is not None else np.gradient(energy, x)
    width = max(1, x.size // 40)  # a running mean, so that noise makes no spurious zeros
    smooth = np.convolve(slope, np.ones(width) / width, mode="same")
    # the force's first peak: the largest value before it first falls 5 % below its running
    # largest value (a curve may rise again far beyond its inverted state)
    running = np.maximum.accumulate(smooth)
    falls = np.nonzero((running > 0) & (smooth < 0.95 * running))[0]
    if not falls.size:
        return None, float("nan")
    peak = int(np.argmax(smooth[: falls[0]]))
    downs = np.nonzero((smooth[peak:-1] > 0) & (smooth[peak + 1 :] <= 0))[0] + peak
    if downs.size and not ghost:
        ups = np.nonzero((smooth[downs[0] : -1] < 0) & (smooth[downs[0] + 1 :] >= 0))[0]
        if ups.size:
            i = int(ups[0] + downs[0])
            return "rest", float(x[i] - smooth[i] * (x[i + 1] - x[i]) / (smooth[i + 1] - smooth[i]))
        return None, float("nan")
    j = peak + int(np.argmin(smooth[peak:]))
    if j >= x.size - 1 - width:  # the force still falls at the curve's end: no ghost on it
        return None, float("nan")
    return "ghost", float(x[j])


def _slope_on(x: NDArray, energy: NDArray, force: NDArray | None, on: NDArray):
    """``F'(0)`` and its sigma from ``E = c2 x² + c3 x³ + c4 x⁴`` (and ``F = E'``) on ``on``."""
    s = x[on]
    e_scale = float(np.sqrt(np.mean(energy[on] ** 2))) or 1.0
    rows = [np.column_stack([s**2, s**3, s**4]) / e_scale]
    data = [energy[on] / e_scale]
    if force is not None:
        f_scale = float(np.sqrt(np.mean(force[on] ** 2))) or 1.0
        rows.append(np.column_stack([2 * s, 3 * s**2, 4 * s**3]) / f_scale)
        data.append(force[on] / f_scale)
    A, b = np.vstack(rows), np.concatenate(data)
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    residual = A @ coef - b
    sigma2 = float(residual @ residual) / max(b.size - 3, 1)
    try:
        var = float(np.linalg.inv(A.T @ A)[0, 0]) * sigma2
    except np.linalg.LinAlgError:
        var = np.inf
    return 2.0 * float(coef[0]), 2.0 * float(np.sqrt(max(var, 0.0)))


def _initial_slope(x, energy, force, x_far, windows):
    """The slope on the largest window that agrees with every smaller one (Lepski's rule).

    Noisy data get a wide window, a curve that bends early (a shell) a narrow one.
    """
    estimates = []
    for w in sorted(windows):
        on = x <= w * x_far
        if on.sum() < MIN_WINDOW_POINTS:
            continue
        estimates.append((w, *_slope_on(x, energy, force, on)))
    if not estimates:
        on = np.zeros(x.size, bool)
        on[:MIN_WINDOW_POINTS] = True
        return (*_slope_on(x, energy, force, on), float(x[on].max() / x_far))
    chosen = estimates[0]
    for j, (w, slope, std) in enumerate(estimates[1:], start=1):
        if all(
            abs(slope - s_i) <= AGREE * max(std_i, 1e-12 * abs(s_i))
            for _, s_i, std_i in estimates[:j]
        ):
            chosen = (w, slope, std)
        else:
            break
    return chosen[1], chosen[2], chosen[0]


def curve_features(
    curve: UnitCellCurve, *, windows: tuple[float, ...] = WINDOWS, ghost: bool = False
) -> CurveFeatures | None:
    """The features of one curve (module docstring); None when it has no far state."""
    x, energy, force = curve.displacement, curve.energy, curve.force
    if energy is None:  # force only: integrate it (trapezoid) from the first point
        energy = np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(x))])
    kind, crude = _far_state(x, energy, force, ghost)
    if kind is None:
        return None
    p = _local_poly(x, energy, force, crude, LOCAL * crude)
    if kind == "rest":
        roots = [
            r.real for r in p.deriv().roots() if abs(r.imag) < 1e-12 and p.deriv(2)(r.real) > 0
        ]
        shift = min(roots, key=abs) if roots else 0.0
        far_f = 0.0
    else:
        inflections = [r.real for r in p.deriv(2).roots() if abs(r.imag) < 1e-12]
        shift = min(inflections, key=abs) if inflections else 0.0
        far_f = float(p.deriv()(shift))
    x_far, e_far = crude + shift, float(p(shift))
    # initial slope: E = c2 x² + c3 x³ + c4 x⁴ (and F its derivative) on x <= window · x_far,
    # on the first branch's own points when the curve is an envelope
    if isinstance(curve, PathCurve) and curve.start_displacement is not None:
        x, energy, force = curve.start_displacement, curve.start_energy, curve.start_force
        if energy is None:
            energy = np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(x))])
    slope, slope_std, used = _initial_slope(x, energy, force, x_far, windows)
    x, energy, force = curve.displacement, curve.energy, curve.force
    if energy is None:
        energy = np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(x))])
    if isinstance(curve, PathCurve) and curve.start_force is not None:
        peak_force = float(np.max(curve.start_force))  # the first branch's (an envelope has none)
    else:
        peak_force = None if force is None else float(np.max(force[x <= x_far]))
    before = x <= x_far
    return CurveFeatures(
        slope=slope,
        slope_std=slope_std,
        slope_window=used,
        far_kind=kind,
        far_displacement=float(x_far),
        far_energy=e_far,
        far_force=far_f,
        barrier_energy=float(np.max(energy[before])),
        peak_force=peak_force,
    )


def quartic_from_features(
    slope: float, far_kind: str, far_displacement: float, far_value: float
) -> tuple[float, float, float]:
    """``(a2, a3, a4)`` of the quartic with these features, exactly (module docstring).

    ``far_value`` is the energy at a rest (N·mm) or the force at a ghost (N).
    """
    a2, x = 0.5 * slope, far_displacement
    if far_kind == "rest":  # F(x) = 0, E(x) = far_value
        e2 = a2 * x * x
        return a2, (4 * far_value - 2 * e2) / x**3, (e2 - 3 * far_value) / x**4
    if far_kind == "ghost":  # F'(x) = 0, F(x) = far_value
        A = np.array([[6 * x, 12 * x * x], [3 * x * x, 4 * x**3]])
        b = np.array([-2 * a2, far_value - 2 * a2 * x])
        a3, a4 = np.linalg.solve(A, b)
        return a2, float(a3), float(a4)
    raise ValueError(f"far_kind={far_kind!r}: must be 'rest' or 'ghost'")


def _law_features(k_b: float, alpha: float, d: float) -> dict[str, float]:
    """The same features read off the law itself (its own far state, barrier and peak)."""
    a2, a3, a4 = 0.5 * k_b, -k_b * (1 - alpha) / d, 0.5 * k_b * (1 - alpha) / d**2
    out = {"slope": k_b}
    disc = 9 * a3 * a3 - 32 * a2 * a4  # F/x = 2 a2 + 3 a3 x + 4 a4 x²
    if disc >= 0:
        x1 = (-3 * a3 - np.sqrt(disc)) / (8 * a4)
        x2 = (-3 * a3 + np.sqrt(disc)) / (8 * a4)
        out["far_displacement"] = float(x2)
        out["far_energy"] = float(spring_energy(np.array(x2), k_b, alpha, d))
        out["far_force"] = 0.0
        out["barrier_energy"] = float(spring_energy(np.array(x1), k_b, alpha, d))
        xs = np.linspace(0.0, x2, 2001)
    else:
        # the force's least value beyond its peak: the larger root of F' = 2 a2 + 6 a3 x + 12 a4 x²
        roots = np.roots([12 * a4, 6 * a3, 2 * a2])
        xg = float(max(r.real for r in roots)) if np.all(np.isreal(roots)) else -a3 / (4 * a4)
        out["far_displacement"] = xg
        out["far_energy"] = float(spring_energy(np.array(xg), k_b, alpha, d))
        out["far_force"] = float(spring_force(np.array(xg), k_b, alpha, d))
        xs = np.linspace(0.0, xg, 2001)
        out["barrier_energy"] = float(spring_energy(xs, k_b, alpha, d).max())
    out["peak_force"] = float(spring_force(xs, k_b, alpha, d).max())
    return out


def _solve(feats: CurveFeatures) -> tuple[float, float, float]:
    far_value = feats.far_energy if feats.far_kind == "rest" else feats.far_force
    return quartic_from_features(feats.slope, feats.far_kind, feats.far_displacement, far_value)


def fit_features(
    curve: UnitCellCurve, *, windows: tuple[float, ...] = WINDOWS, ghost: bool = False
) -> FeatureFit:
    """Match the spring law to the features of one curve (module docstring).

    With ``ghost``, the far state is the force's least value beyond its peak even where the
    curve has a rest (a rest that only just touches zero force, next to the bistable edge).
    """
    feats = curve_features(curve, windows=windows, ghost=ghost)
    if feats is None:
        return FeatureFit(
            curve=curve.curve,
            k_b=float("nan"),
            alpha=float("nan"),
            d=float("nan"),
            correlation_alpha_d=float("nan"),
            relative_rms=float("nan"),
            flags=("no far state on the curve (no inverted rest and no least force)",),
        )
    a2, a3, a4 = _solve(feats)
    if feats.far_kind == "rest" and not (a2 > 0 and a4 > 0 and a3 < 0):
        # a rest the quartic cannot carry is a force that only just touches zero (a unit at
        # alpha ≈ 1/9, or noise): take the force's least value, the ghost it is near
        ghost = curve_features(curve, windows=windows, ghost=True)
        if ghost is not None and ghost.far_kind == "ghost":
            feats = ghost
            a2, a3, a4 = _solve(feats)
    flags = []
    if curve.folded and not (isinstance(curve, PathCurve) and curve.start_displacement is not None):
        flags.append(
            "a folded curve's envelope without its first branch: the initial slope is biased "
            "(read the table with read_feature_curves)"
        )
    values = {
        "slope": feats.slope,
        "far_displacement": feats.far_displacement,
        "far_energy": feats.far_energy,
        "barrier_energy": feats.barrier_energy,
    }
    if feats.far_kind == "ghost":
        values["far_force"] = feats.far_force
    if feats.peak_force is not None:
        values["peak_force"] = feats.peak_force
    if not (a2 > 0 and a4 > 0 and a3 < 0):
        flags.append(
            f"the features give no snapping spring (a2 = {a2:.4g}, a3 = {a3:.4g}, a4 = {a4:.4g})"
        )
        return FeatureFit(
            curve=curve.curve,
            k_b=2 * a2,
            alpha=float("nan"),
            d=float("nan"),
            correlation_alpha_d=float("nan"),
            relative_rms=float("nan"),
            flags=tuple(flags),
            features=values,
        )
    k_b, d, alpha = 2 * a2, -a3 / (2 * a4), 1 - a3 * a3 / (4 * a2 * a4)
    law = _law_features(k_b, alpha, d)
    if feats.far_kind == "rest" and not np.isclose(
        law.get("far_displacement", np.nan), feats.far_displacement, rtol=1e-6
    ):
        flags.append("the inverted rest is the matched law's barrier, not its second minimum")
    x, energy = curve.displacement, curve.energy
    if energy is not None:
        on = x <= feats.far_displacement
        scale = float(np.sqrt(np.mean(energy[on] ** 2))) or 1.0
        rms = float(np.sqrt(np.mean((spring_energy(x[on], k_b, alpha, d) - energy[on]) ** 2)))
        relative_rms = rms / scale
    else:
        on = x <= feats.far_displacement
        scale = float(np.sqrt(np.mean(curve.force[on] ** 2))) or 1.0
        rms = float(np.sqrt(np.mean((spring_force(x[on], k_b, alpha, d) - curve.force[on]) ** 2)))
        relative_rms = rms / scale
    return FeatureFit(
        curve=curve.curve,
        k_b=float(k_b),
        alpha=float(alpha),
        d=float(d),
        correlation_alpha_d=0.0,
        relative_rms=relative_rms,
        flags=tuple(flags),
        features=values,
        law=law,
    )
