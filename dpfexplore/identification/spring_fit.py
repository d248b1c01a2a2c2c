"""The dome spring law fitted to one unit-cell curve (MODEL.md §4, §11).

The law ``E_NL(x) = ½ k_b x² (1 + (1 − α)(u² − 2u))``, ``u = x/d``, is a quartic without constant
or linear term, ``E_NL = a2 x² + a3 x³ + a4 x⁴`` with ``a2 = k_b/2``, ``a3 = −k_b (1 − α)/d``,
``a4 = k_b (1 − α)/(2 d²)``; so ``k_b = 2 a2``, ``d = −a3/(2 a4)``, ``α = 1 − a3²/(4 a2 a4)``.
It is linear in ``(a2, a3, a4)``: a joint energy-and-force linear least squares (each block
scaled by its RMS) gives a unique start without a guess. Then a bounded robust least squares
(:func:`scipy.optimize.least_squares`, ``soft_l1``) in ``(k_b, α, d)`` with ``k_b > 0``,
``0 < α < 1``, ``d > 0``, and a covariance from its Jacobian.

A fit is *flagged*, not silently kept, when the curve does not determine it: it ends before
the reach ``d`` (so the inverted side of the law is extrapolated), the law has no energy dip
left to pin ``α`` and ``d`` (their correlation above :data:`TRADE_OFF`), or its relative RMS
residual exceeds the caller's limit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from .curves import UnitCellCurve

__all__ = ["TRADE_OFF", "CurveFit", "fit_curve", "spring_energy", "spring_force"]

#: Absolute correlation of α and d above which the curve does not identify them separately.
TRADE_OFF = 0.995
#: Fraction of the reach ``d`` a curve must cover for the law's far side to be measured.
MIN_COVER = 0.9


def spring_energy(x: NDArray, k_b: float, alpha: float, d: float) -> NDArray:
    """``E_NL`` of MODEL.md §4 at extensions ``x`` (mm), N·mm."""
    u = x / d
    return 0.5 * k_b * x * x * (1.0 + (1.0 - alpha) * (u * u - 2.0 * u))


def spring_force(x: NDArray, k_b: float, alpha: float, d: float) -> NDArray:
    """``d E_NL / dx`` at ``x`` (mm), N."""
    u = x / d
    return k_b * x * (1.0 + (1.0 - alpha) * (2.0 * u * u - 3.0 * u))


@dataclass(frozen=True)
class CurveFit:
    """The spring law fitted to one curve.

    Attributes
    ----------
    curve : str
    k_b : float, N/mm
    alpha : float
    d : float, mm
        The law's reach fitted to this curve (the lattice's ``d`` comes from ``tip_dis``).
    std : dict
        One-sigma uncertainties of ``k_b``, ``alpha``, ``d`` from the Jacobian.
    correlation_alpha_d : float
    relative_rms : float
        RMS of the energy (or force) residual over the RMS of the data.
    flags : tuple of str
        Why the fit cannot be trusted (empty when it can).
    """

    curve: str
    k_b: float
    alpha: float
    d: float
    std: dict[str, float] = field(default_factory=dict)
    correlation_alpha_d: float = 0.0
    relative_rms: float = 0.0
    flags: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """No flag raised."""
        return not self.flags


def _blocks(curve: UnitCellCurve) -> tuple[NDArray, NDArray, list[tuple[float, slice]]]:
    """Design matrix and data of the joint linear problem in ``(a2, a3, a4)``."""
    x = curve.displacement
    rows, data, scales = [], [], []
    start = 0
    if curve.energy is not None:
        scale = float(np.sqrt(np.mean(curve.energy**2))) or 1.0
        rows.append(np.column_stack([x**2, x**3, x**4]) / scale)
        data.append(curve.energy / scale)
        scales.append((scale, slice(start, start + x.size)))
        start += x.size
    if curve.force is not None:
        scale = float(np.sqrt(np.mean(curve.force**2))) or 1.0
        rows.append(np.column_stack([2 * x, 3 * x**2, 4 * x**3]) / scale)
        data.append(curve.force / scale)
        scales.append((scale, slice(start, start + x.size)))
    return np.vstack(rows), np.concatenate(data), scales


def _residuals(theta: NDArray, curve: UnitCellCurve) -> NDArray:
    k_b, alpha, d = theta
    x = curve.displacement
    parts = []
    if curve.energy is not None:
        scale = float(np.sqrt(np.mean(curve.energy**2))) or 1.0
        parts.append((spring_energy(x, k_b, alpha, d) - curve.energy) / scale)
    if curve.force is not None:
        scale = float(np.sqrt(np.mean(curve.force**2))) or 1.0
        parts.append((spring_force(x, k_b, alpha, d) - curve.force) / scale)
    return np.concatenate(parts)


def fit_curve(curve: UnitCellCurve, *, max_relative_rms: float = 0.05) -> CurveFit:
    """Fit the spring law to one curve (module docstring); flags say when not to trust it."""
    A, b, _ = _blocks(curve)
    (a2, a3, a4), *_ = np.linalg.lstsq(A, b, rcond=None)
    flags = []
    if a2 > 0 and a4 > 0 and a3 < 0:
        start = np.array([2 * a2, 1 - a3 * a3 / (4 * a2 * a4), -a3 / (2 * a4)])
    else:  # not a dome-like quartic: start from a plain spring reaching to the curve's end
        flags.append("the linear fit is not a snapping spring (a2, a4 > 0 > a3 fails)")
        start = np.array([max(2 * a2, 1e-9), 0.5, float(curve.displacement.max())])
    start[1] = np.clip(start[1], 1e-6, 1 - 1e-6)
    start[0] = max(start[0], 1e-12)
    start[2] = max(start[2], 1e-9)
    linear = _residuals(start, curve)
    noise = 1.4826 * float(np.median(np.abs(linear - np.median(linear)))) or 1e-3
    result = least_squares(
        _residuals,
        start,
        args=(curve,),
        bounds=([1e-12, 1e-9, 1e-9], [np.inf, 1 - 1e-9, np.inf]),
        loss="soft_l1",
        f_scale=max(3.0 * noise, 1e-6),
        x_scale="jac",
    )
    k_b, alpha, d = (float(v) for v in result.x)
    residual = _residuals(result.x, curve)
    dof = max(residual.size - 3, 1)
    sigma2 = float(residual @ residual) / dof
    J = result.jac
    try:
        cov = np.linalg.inv(J.T @ J) * sigma2
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        corr = float(cov[1, 2] / (std[1] * std[2])) if std[1] > 0 and std[2] > 0 else 1.0
    except np.linalg.LinAlgError:
        std, corr = np.full(3, np.inf), 1.0
        flags.append("singular Jacobian: the curve does not determine k_b, alpha and d")
    relative_rms = float(np.sqrt(np.mean(residual**2)))
    if curve.displacement.max() < MIN_COVER * d:
        flags.append(
            f"ends at {curve.displacement.max():.4g} mm, before the reach d = {d:.4g} mm: the "
            "inverted side of the law is extrapolated"
        )
    if abs(corr) > TRADE_OFF:
        flags.append(f"alpha and d trade off (correlation {corr:+.4f})")
    if relative_rms > max_relative_rms:
        flags.append(f"relative RMS residual {relative_rms:.3g} > {max_relative_rms:g}")
    return CurveFit(
        curve=curve.curve,
        k_b=k_b,
        alpha=alpha,
        d=d,
        std={"k_b": float(std[0]), "alpha": float(std[1]), "d": float(std[2])},
        correlation_alpha_d=corr,
        relative_rms=relative_rms,
        flags=tuple(flags),
    )
