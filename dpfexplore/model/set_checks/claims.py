"""What a constants set claims about its domain, proven: physical forms, a consistent hull.

A set claims that its closed forms describe domes over its domain (MODEL.md §3, §11). Checked
here, in this order, each refusal one line:

1. **Magnitudes.** Every coefficient within ``±MAX_COEFFICIENT`` and every range of the domain
   within :data:`DOMAIN_LIMITS`: what a dome of a soft finger can have, with wide margins
   (``docs/decisions.md``, "Constants sets: proven claims").
2. **The hull.** When a set carries the convex hull of its data in ``(H/r_b, t/r_b)``, the hull
   must be one (counter-clockwise, convex, simple), lie inside the ranges of ``H/r_b`` and
   ``t/r_b``, cover at least :data:`HULL_MIN_AREA` of their box, and, when the set states
   those ranges, reach each of them: they are its data's extremes, which are vertices of the
   data's hull. A hull that misses them does not hold the points the ranges claim.
3. **The forms.** For each closed form, :data:`FORM_BOUNDS` over the whole domain (the box of
   the ratio ranges, within the hull), proven by Bernstein enclosures
   (:mod:`~dpfexplore.model.set_checks.bounds`), not sampled: ``k_hat`` in ``(0, 1e4)`` (so
   ``k_b > 0``), ``alpha`` in ``(0, 1)``, ``tip_ratio`` in ``(1, 100)`` (so ``tip_dis > H``).
   ``k_b`` scales with ``E > 0`` and ``tip_dis`` with ``H``, so the dimensionless forms decide.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..closed_form import ClosedForm
from ..quantities import SET_FORMS
from .bounds import Bound, first_violation

__all__ = [
    "DOMAIN_LIMITS",
    "FORM_BOUNDS",
    "HULL_MIN_AREA",
    "MAX_COEFFICIENT",
    "claims_problem",
    "data_hull",
]

#: Largest coefficient magnitude of a closed form. The packaged sets' largest is 379
#: (``shell-extended``), the paper's 71.8; a fit that needs coefficients near 1e6 cancels to
#: six digits and its values are noise.
MAX_COEFFICIENT = 1e6
#: Open bounds ``(low, high)`` of each dimensionless form over the domain. The lower ones are
#: the physical conditions of :data:`~dpfexplore.model.quantities.SET_FORMS` (``k_b > 0``,
#: ``0 < alpha < 1``, ``tip_dis > H``); the upper ones keep the forms finite: ``k_hat`` is
#: 2.1-5.2 in the packaged sets and ~2.4 for a shallow shell (Reissner), ``tip_ratio`` 1.6-2.3
#: (about 2 for an inversion that mirrors the cap).
FORM_BOUNDS: dict[str, tuple[float, float]] = {
    "k_hat": (0.0, 1e4),
    "alpha": (0.0, 1.0),
    "tip_ratio": (1.0, 100.0),
}
#: What a domain's ranges may state: ``name: (least low, largest high, unit)``. Lengths from a
#: micrometre to a metre, ``E`` up to 1 TPa, ``nu`` of an isotropic solid, ratios 1e-3 to 100.
#: The ratios' lower ends also keep ``π1 = t/H`` and ``π3`` away from zero and infinity.
DOMAIN_LIMITS: dict[str, tuple[float, float, str]] = {
    "H": (1e-3, 1e3, "mm"),
    "t": (1e-3, 1e3, "mm"),
    "r_b": (1e-3, 1e3, "mm"),
    "E": (1e-3, 1e6, "MPa"),
    "nu": (-1.0, 0.5, ""),
    "H_over_rb": (1e-3, 1e2, ""),
    "t_over_rb": (1e-3, 1e2, ""),
}
#: Least area of a hull, as a fraction of the box of its ranges.
HULL_MIN_AREA = 1e-3
#: Relative tolerance of the hull's vertices against its ranges.
HULL_TOLERANCE = 1e-9


def claims_problem(
    forms: Mapping[str, ClosedForm],
    domain: Mapping[str, tuple[float, float]],
    ratio_ranges: tuple[tuple[float, float], tuple[float, float]],
    hull: NDArray | None,
) -> str | None:
    """What a set's claims get wrong (one line, without the set's name), or None.

    Parameters
    ----------
    forms : mapping of str to ClosedForm
        The set's closed forms, by the names of
        :data:`~dpfexplore.model.quantities.SET_FORMS`.
    domain : mapping of str to (float, float)
        Its ranges (:data:`DOMAIN_LIMITS` names them).
    ratio_ranges : ((float, float), (float, float))
        The ranges of ``H/r_b`` and ``t/r_b`` the domain bounds (stated or derived).
    hull : ndarray of shape (n, 2), optional
        Vertices of its data's hull in ``(H/r_b, t/r_b)``.
    """
    for form in SET_FORMS:
        for c in forms[form.name].coefficients:
            if not abs(c) <= MAX_COEFFICIENT:
                return (
                    f"{form.name} has a coefficient {c:.4g}, beyond ±{MAX_COEFFICIENT:g} "
                    "(a physical set's are below 1e3)"
                )
    for key, (low, high) in domain.items():
        least, largest, unit = DOMAIN_LIMITS[key]
        if not least <= low <= high <= largest:
            return (
                f"domain.{key} = [{low:.4g}, {high:.4g}]: must lie within "
                f"{least:g}-{largest:g}{' ' + unit if unit else ''}"
            )
    (h0, h1), (s0, s1) = ratio_ranges
    for name, low, high in (("H_over_rb", h0, h1), ("t_over_rb", s0, s1)):
        least, largest, _ = DOMAIN_LIMITS[name]
        if not least <= low <= high <= largest:
            return (
                f"its domain spans {name} {low:.4g}-{high:.4g}: must lie within "
                f"{least:g}-{largest:g}"
            )
    if hull is not None:
        stated = "H_over_rb" in domain and "t_over_rb" in domain
        problem = _hull_problem(hull, ratio_ranges, stated)
        if problem:
            return problem
    return _forms_problem(forms, ratio_ranges, hull)


def _hull_problem(
    hull: NDArray, ratio_ranges: tuple[tuple[float, float], tuple[float, float]], stated: bool
) -> str | None:
    (h0, h1), (s0, s1) = ratio_ranges
    if not (h1 > h0 and s1 > s0):
        return "a hull needs ranges of H/r_b and t/r_b of positive width"
    low, high = hull.min(axis=0), hull.max(axis=0)
    tol = HULL_TOLERANCE * np.array([max(abs(h0), abs(h1)), max(abs(s0), abs(s1))])
    span = f"the hull spans H/r_b {low[0]:.4g}-{high[0]:.4g}, t/r_b {low[1]:.4g}-{high[1]:.4g}"
    ranges = f"H/r_b {h0:.4g}-{h1:.4g}, t/r_b {s0:.4g}-{s1:.4g}"
    if np.any(low < np.array([h0, s0]) - tol) or np.any(high > np.array([h1, s1]) + tol):
        return f"{span}, beyond its ranges ({ranges})"
    if stated and (
        np.any(np.abs(low - np.array([h0, s0])) > tol)
        or np.any(np.abs(high - np.array([h1, s1])) > tol)
    ):
        return (
            f"{span}, not its ranges ({ranges}): the ranges are its data's extremes, "
            "which are vertices of the data's hull"
        )
    edges = np.roll(hull, -1, axis=0) - hull
    nxt = np.roll(edges, -1, axis=0)
    cross = edges[:, 0] * nxt[:, 1] - edges[:, 1] * nxt[:, 0]
    dot = np.einsum("ij,ij->i", edges, nxt)
    lengths = np.hypot(edges[:, 0], edges[:, 1]) * np.hypot(nxt[:, 0], nxt[:, 1])
    turning = float(np.arctan2(cross, dot).sum())
    if np.any(cross < -1e-12 * lengths) or abs(turning - 2.0 * np.pi) > 1e-6:
        return "the hull is not a convex polygon with counter-clockwise vertices"
    area = 0.5 * float(
        np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
    )
    if area < HULL_MIN_AREA * (h1 - h0) * (s1 - s0):
        return (
            f"the hull covers {area / ((h1 - h0) * (s1 - s0)):.2g} of the box of its ranges, "
            f"less than {HULL_MIN_AREA:g}"
        )
    return None


def _forms_problem(
    forms: Mapping[str, ClosedForm],
    ratio_ranges: tuple[tuple[float, float], tuple[float, float]],
    hull: NDArray | None,
) -> str | None:
    bounds, texts = [], []
    for form in SET_FORMS:
        closed = forms[form.name]
        low, high = FORM_BOUNDS[form.name]
        bounds.append(Bound(closed.exponents, closed.coefficients, low, upper=False))
        texts.append((form.unphysical, form.name, low))
        bounds.append(Bound(closed.exponents, closed.coefficients, high, upper=True))
        above = form.unphysical if form.name == "alpha" else f"{form.name} >= {high:g}"
        texts.append((above, form.name, high))
    # the box as in_domain takes it (to 1e-12 of each end)
    (h0, h1), (s0, s1) = ratio_ranges
    widen = 1.0 + 1e-12
    found = first_violation(bounds, (h0 / widen, h1 * widen), (s0 / widen, s1 * widen), hull)
    if found is None:
        return None
    text, name, limit = texts[found.index]
    where = f"H/r_b = {found.h:.4g}, t/r_b = {found.s:.4g}"
    if found.found:
        return f"{text} inside its own domain, at {where}"
    side = "below" if bounds[found.index].upper else "above"
    return (
        f"{text} not ruled out inside its own domain ({name} not proven {side} {limit:g} "
        f"near {where})"
    )


def data_hull(h: ArrayLike, s: ArrayLike) -> tuple[tuple[float, float], ...] | None:
    """The counter-clockwise convex hull of points ``(H/r_b, t/r_b)``; None when degenerate."""
    from scipy.spatial import ConvexHull, QhullError

    points = np.column_stack([np.ravel(h), np.ravel(s)]).astype(float)
    points = np.unique(points[np.all(np.isfinite(points), axis=1)], axis=0)
    if points.shape[0] < 3:
        return None
    try:
        hull = ConvexHull(points)
    except QhullError:  # collinear: the ranges say all there is
        return None
    return tuple((float(x), float(y)) for x, y in points[hull.vertices])  # 2-D: counter-clockwise
