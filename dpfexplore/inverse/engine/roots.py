"""Roots along one variable of the unit box: brackets and Brent's method, scene-agnostic.

The timing scenes (pick-and-place, walker) look for the dome height at which a unit's reset time
meets its target: a root of ``log(reset / target)`` along one box variable. Reset times are
infinite for bistable units and undefined (NaN) where a design is not admissible, so the
functions here work on log ratios clipped to ``±`` :data:`LOG_INF` and on brackets whose ends
may carry those values.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["LOG_INF", "finite_log", "grow_bracket", "root_on_line"]

logger = logging.getLogger(__name__)

#: ``log(objective / target)`` standing for an infinite ratio (a bistable unit never resets)
#: and, negated, for a non-positive one (a unit that resets before the release ends).
LOG_INF = 50.0


class _Hit(Exception):
    def __init__(self, x: float) -> None:
        self.x = x


def root_on_line(
    func,
    x_lo: float,
    x_hi: float,
    f_lo: float,
    f_hi: float,
    *,
    ftol: float,
    xtol: float = 1e-10,
    max_iter: int = 80,
) -> tuple[float, int]:
    """Root of ``func`` (a log ratio) in ``[x_lo, x_hi]`` by Brent's method; early stop at ``ftol``.

    ``func`` returns ``±`` :data:`LOG_INF` where the objective is infinite or negative (a
    bistable end diverges; Brent's interpolation cannot use it), so while an end carries that
    value the bracket is first halved; NaN (not admissible) counts as the side of the end it
    replaces, which keeps a bracket whose interior changes class closing on the sign change.

    Returns
    -------
    x : float
        The root (or the point where ``|func| <= ftol``).
    evaluations : int
    """
    calls = [0]

    def f(x: float) -> float:
        calls[0] += 1
        value = func(x)
        if np.isfinite(value) and abs(value) <= ftol:
            raise _Hit(x)
        return value

    a, b, fa, fb = x_lo, x_hi, f_lo, f_hi
    try:
        for _ in range(max_iter):
            if abs(fa) < LOG_INF and abs(fb) < LOG_INF:
                break
            m = 0.5 * (a + b)
            fm = f(m)
            if not np.isfinite(fm):
                fm = fa if abs(fa) >= LOG_INF else fb
            if (fm < 0) == (fa < 0):
                a, fa = m, fm
            else:
                b, fb = m, fm
            if abs(b - a) <= xtol:
                return 0.5 * (a + b), calls[0]

        def g(x: float) -> float:
            value = f(x)
            return value if np.isfinite(value) else (fa if x < 0.5 * (a + b) else fb)

        x = brentq(g, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=max_iter)
    except _Hit as hit:
        return hit.x, calls[0]
    except ValueError as exc:  # the bracket lost its sign change (a class jump): its middle
        logger.debug("root_on_line: %s", exc)
        return 0.5 * (a + b), calls[0]
    return float(x), calls[0]


def finite_log(value: float, target: float) -> float:
    """``log(value / target)`` clipped to ``±`` :data:`LOG_INF` (NaN stays NaN)."""
    if math.isnan(value):
        return math.nan
    if value == math.inf:
        return LOG_INF
    if value <= 0:
        return -LOG_INF
    return math.log(value / target)


def grow_bracket(
    func, x0: float, *, lo: float = 0.0, hi: float = 1.0, step: float = 0.01, limit: int = 12
) -> tuple[float, float, float, float] | None:
    """A sign change of ``func`` near ``x0`` in ``[lo, hi]``: steps doubling on either side.

    Returns ``(a, b, f(a), f(b))`` with ``a < b``, or None (no finite ``f(x0)`` or no sign
    change within ``limit`` doublings).
    """
    f0 = func(x0)
    if not np.isfinite(f0):
        return None
    for k in range(limit):
        d = step * 2.0**k
        for x in (x0 + d, x0 - d):
            if not lo <= x <= hi:
                continue
            fx = func(x)
            if np.isfinite(fx) and (fx < 0) != (f0 < 0):
                return (x0, x, f0, fx) if x > x0 else (x, x0, fx, f0)
        if x0 + d > hi and x0 - d < lo:
            break
    return None
