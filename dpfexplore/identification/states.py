"""The dome spring law matched to the unit's states: its inverted rest, stiffness and barrier.

A dome with no apex load has the states the lattice's law stands for (MODEL.md §4): the
undeformed dome (the law's first minimum, stiffness ``k_b``), the inverted rest (its second
minimum) and the barrier between them, the free dome's saddle (the law's maximum). The dome
offers four features of those states, the law has three parameters:

1. the inverted rest's travel ``x_rest`` and energy ``E_rest`` are matched exactly (the rest is
   an equilibrium with no apex load: neither the run's control nor a fit range changes it);
2. that leaves one parameter, the law's ``k_b`` (with ``k_b``, the rest fixes ``(a3, a4)`` by a
   linear solve, :func:`~.features.quartic_from_features`), chosen by least squares of the two
   misfits that remain, relative and in logarithms, with equal weights:
   ``log(k_b / F'(0))²`` (the initial stiffness) ``+ log(E_barrier,law / E_saddle)²`` (the
   barrier). Both vanish at once on a curve drawn from the law, which is then recovered
   exactly.

``k_b`` runs over ``(12 E_rest / x_rest², ∞)``: below, the rest would be the law's barrier, not
its second minimum (:mod:`.features`), and there the law's barrier falls to the rest's energy;
above, it rises with ``k_b``, so the cost has one minimum.

**The barrier** is read off the path: the lowest energy of a zero-force state of the path,
other than the start, above the inverted rest's energy and before its travel. On a folded shell
path (a table with ``branch``) the zero-force states are found per step of the path, on the
cubic Hermite interpolant of the energy with the force as its slope; over the paper's box the
lowest is the free dome's lowest saddle of index 1 (the unit-cell guide), which the path
crosses on an unstable branch. On a plain curve (no branch) it is the energy's maximum before
the rest, refined by a local polynomial (noise). A dome with no inverted rest (a ghost)
has no barrier: its law is the features fit's (initial slope and ghost); so has a plain
curve's rest with no maximum above it (a rest at the bistable edge, its barrier merged into it,
or noise dipping the force below zero next to one). A path's rest without a barrier on the path
is flagged.

Where it stands among the per-curve fits (unit-cell guide, "Against the paper's closed
forms"): over the paper's box it reproduces the paper's per-dome constants best of the
physically defined recipes tried; the initial slope alone (:mod:`.features`) leaves ``k_b``
half the paper's and ``α`` high, the barrier alone doubles ``k_b``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from .curves import CurveError, UnitCellCurve, read_curve_table
from .features import (
    LOCAL,
    FeatureFit,
    PathCurve,
    _law_features,
    _local_poly,
    curve_features,
    feature_curves_from_frame,
    fit_features,
    quartic_from_features,
)
from .spring_fit import spring_energy, spring_force

__all__ = [
    "StatesCurve",
    "fit_states",
    "path_zero_force",
    "read_states_curves",
    "states_curves_from_frame",
]

#: The law's ``k_b`` is searched up to this many times its smallest (the merge of its rest and
#: barrier); a barrier that far above the rest is out of any quartic's reach.
K_SPAN = 1e4
#: A zero-force state counts as a barrier when its energy exceeds the rest's by this fraction
#: (the rest's own crossing, refined differently, lies within 1e-4 of it).
REST_MARGIN = 1e-3


@dataclass(frozen=True)
class StatesCurve(PathCurve):
    """A checked curve with its first branch and the zero-force states of its whole path.

    Attributes
    ----------
    zero_force : tuple of (float, float)
        ``(travel mm, energy N·mm)`` of every zero-force state the path crosses
        (:func:`path_zero_force`); empty for a plain curve, whose barrier is read off the curve
        itself.
    """

    zero_force: tuple[tuple[float, float], ...] = ()


def path_zero_force(
    displacement: NDArray, energy: NDArray, force: NDArray, branch: NDArray
) -> list[tuple[float, float]]:
    """The zero-force states a traced path crosses: ``(travel mm, energy N·mm)``.

    Per step of one branch (monotone in the travel) whose end forces have opposite signs: the
    zero of the derivative of the step's cubic Hermite interpolant of the energy (slopes: the
    forces) nearest the linear estimate, and the energy there.
    """
    out = []
    for i in range(1, displacement.size):
        if branch[i] != branch[i - 1] or not force[i - 1] * force[i] < 0.0:
            continue
        h = displacement[i] - displacement[i - 1]
        if h == 0.0:
            continue
        e0, e1, m0, m1 = energy[i - 1], energy[i], force[i - 1] * h, force[i] * h
        c3, c2, c1 = 2 * e0 + m0 - 2 * e1 + m1, -3 * e0 - 2 * m0 + 3 * e1 - m1, m0
        roots = [
            r.real
            for r in np.roots([3 * c3, 2 * c2, c1])
            if abs(r.imag) < 1e-12 and -1e-9 <= r.real <= 1 + 1e-9
        ]
        linear = force[i - 1] / (force[i - 1] - force[i])
        s = min(roots, key=lambda r: abs(r - linear)) if roots else linear
        out.append((float(displacement[i - 1] + s * h), float(e0 + s * (c1 + s * (c2 + s * c3)))))
    return out


def states_curves_from_frame(frame: pd.DataFrame) -> list[StatesCurve]:
    """The curves of a table, checked as by :func:`~.curves.curves_from_frame`.

    Each keeps its first branch (:class:`~.features.PathCurve`) and, for a folded path with a
    force column, the zero-force states of the whole path.
    """
    paths = feature_curves_from_frame(frame)
    out = []
    for curve, (_, rows) in zip(paths, frame.groupby("curve", sort=False), strict=True):
        zero: list[tuple[float, float]] = []
        if curve.folded and "force" in rows:
            zero = path_zero_force(
                rows["displacement"].to_numpy(dtype=float),
                rows["energy"].to_numpy(dtype=float),
                rows["force"].to_numpy(dtype=float),
                rows["branch"].to_numpy(),
            )
        values = {f.name: getattr(curve, f.name) for f in fields(PathCurve)}
        out.append(StatesCurve(**values, zero_force=tuple(zero)))
    return out


def read_states_curves(path: str | Path) -> list[StatesCurve]:
    """Read and check a table as :func:`~.curves.read_curves` does, paths' states kept."""
    frame = read_curve_table(path)  # the checks and their one-line errors
    try:
        return states_curves_from_frame(frame)
    except CurveError as exc:
        raise CurveError(f"{path}: {exc}") from None


def _curve_barrier(curve: UnitCellCurve, x_rest: float, e_rest: float) -> float | None:
    """The barrier energy (module docstring), N·mm; None if the curve has none."""
    if isinstance(curve, StatesCurve) and curve.zero_force:
        # the rest itself (and anything as low) is not a barrier: above it by 0.1 %
        found = [e for x, e in curve.zero_force if x < x_rest and e > (1 + REST_MARGIN) * e_rest]
        return min(found) if found else None
    if curve.folded:  # an envelope's maximum is where branches cross, not a zero-force state
        return None
    x, energy, force = curve.displacement, curve.energy, curve.force
    if energy is None:
        return None
    before = x < x_rest
    if before.sum() < 5:
        return None
    crude = float(x[before][int(np.argmax(energy[before]))])
    if crude <= x[0] or energy[before].max() <= e_rest:
        return None
    poly = _local_poly(x, energy, force, crude, LOCAL * x_rest)
    stationary = [
        r.real
        for r in poly.deriv().roots()
        if abs(r.imag) < 1e-12 and poly.deriv(2)(r.real) < 0 and abs(r.real) <= LOCAL * x_rest
    ]
    shift = min(stationary, key=abs) if stationary else 0.0
    return float(poly(shift))


def _law(k_b: float, x_rest: float, e_rest: float) -> tuple[float, float, float]:
    """``(k_b, α, d)`` of the quartic with slope ``k_b`` and this inverted rest."""
    a2, a3, a4 = quartic_from_features(k_b, "rest", x_rest, e_rest)
    return 2 * a2, 1 - a3 * a3 / (4 * a2 * a4), -a3 / (2 * a4)


def _law_barrier(k_b: float, alpha: float, d: float) -> float:
    """The law's barrier energy, N·mm (its maximum between the two minima)."""
    a2, a3, a4 = 0.5 * k_b, -k_b * (1 - alpha) / d, 0.5 * k_b * (1 - alpha) / d**2
    x = (-3 * a3 - np.sqrt(max(9 * a3 * a3 - 32 * a2 * a4, 0.0))) / (8 * a4)
    return float(spring_energy(np.array(x), k_b, alpha, d))


def fit_states(curve: UnitCellCurve) -> FeatureFit:
    """Match the spring law to the states of one curve (module docstring)."""
    feats = curve_features(curve)
    if feats is None or feats.far_kind != "rest":
        return fit_features(curve)  # no inverted rest: the ghost's law, or no far state
    x_rest, e_rest, slope = feats.far_displacement, feats.far_energy, feats.slope
    saddle = _curve_barrier(curve, x_rest, e_rest)
    if saddle is None and not (isinstance(curve, StatesCurve) and curve.zero_force):
        # a plain curve whose rest has no maximum above it: a rest at the bistable edge (its
        # barrier merged into it), or noise that dips the force below zero: the ghost it is near
        ghost = fit_features(curve, ghost=True)
        if ghost.ok:
            return ghost
    if saddle is None:
        fit = fit_features(curve)
        flag = (
            "no barrier on the curve (a zero-force maximum above the inverted rest): the law "
            "cannot be balanced between slope and barrier"
        )
        return FeatureFit(**{**_fields(fit), "flags": (*fit.flags, flag)})
    floor = np.log(12.0 * e_rest / x_rest**2)

    def cost(log_k: float) -> float:
        k_b, alpha, d = _law(float(np.exp(log_k)), x_rest, e_rest)
        return np.log(k_b / slope) ** 2 + np.log(_law_barrier(k_b, alpha, d) / saddle) ** 2

    span = (floor + 1e-9, floor + np.log(K_SPAN))
    best = minimize_scalar(cost, bounds=span, method="bounded", options={"xatol": 1e-10})
    k_b, alpha, d = _law(float(np.exp(best.x)), x_rest, e_rest)
    values = {
        "slope": slope,
        "far_displacement": x_rest,
        "far_energy": e_rest,
        "saddle_energy": saddle,
    }
    if feats.peak_force is not None:
        values["peak_force"] = feats.peak_force
    law = _law_features(k_b, alpha, d)
    law["saddle_energy"] = _law_barrier(k_b, alpha, d)
    x, energy = curve.displacement, curve.energy
    on = x <= x_rest
    if energy is not None:
        scale = float(np.sqrt(np.mean(energy[on] ** 2))) or 1.0
        rms = float(np.sqrt(np.mean((spring_energy(x[on], k_b, alpha, d) - energy[on]) ** 2)))
    else:
        scale = float(np.sqrt(np.mean(curve.force[on] ** 2))) or 1.0
        rms = float(np.sqrt(np.mean((spring_force(x[on], k_b, alpha, d) - curve.force[on]) ** 2)))
    flags = []
    if curve.folded and not (isinstance(curve, PathCurve) and curve.start_displacement is not None):
        flags.append(
            "a folded curve's envelope without its first branch: the initial slope is biased "
            "(read the table with read_states_curves)"
        )
    return FeatureFit(
        curve=curve.curve,
        k_b=float(k_b),
        alpha=float(alpha),
        d=float(d),
        correlation_alpha_d=0.0,
        relative_rms=rms / scale,
        flags=tuple(flags),
        features=values,
        law=law,
    )


def _fields(fit: FeatureFit) -> dict:
    return {f.name: getattr(fit, f.name) for f in fields(FeatureFit)}
