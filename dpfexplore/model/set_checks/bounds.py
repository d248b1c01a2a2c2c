"""Proven bounds of closed forms over a domain of ``(H/r_b, t/r_b)``: Bernstein enclosures.

A closed form ``P = Σ c π1^p π3^q`` (:class:`~dpfexplore.model.closed_form.ClosedForm`) is, in
``h = H/r_b`` and ``s = t/r_b`` (``π1 = s/h``, ``π3 = H/R = 2h²/(1 + h²)``), a rational function:
each term is ``c 2^q s^p h^(2q−p) (1 + h²)^(−q)``. Multiplied by the positive factor
``F = s^a h^b (1 + h²)^k`` (``a``, ``b``, ``k`` the least that clear every negative power),
``F (P − lo)`` and ``F (hi − P)`` are polynomials in ``(h, s)`` of degree at most 36 in ``h`` and
12 in ``s`` (powers within ``±MAX_POWER = 6``), with the signs of ``P − lo`` and ``hi − P``
wherever ``h, s > 0``.

On a cell ``[h_a, h_b] × [s_a, s_b]`` such a polynomial is a convex combination of its
Bernstein coefficients, so their least is a lower bound of the polynomial on the whole cell
(Garloff, "Convergent bounds for the range of multivariate polynomials", 1986). A condition
``lo < P`` (or ``P < hi``) is proven on a cell when every Bernstein coefficient exceeds its own
rounding bound: the same computation on the terms' magnitudes, times :data:`ROUNDING`, bounds
what floating point can have lost (every matrix of the conversion is non-negative; the chain
is a few hundred operations deep, each off by at most 2⁻⁵³ relative, so 1e-11 is a margin of
hundreds). A cell where some condition is not proven is split in four, up to :data:`MAX_DEPTH`
halvings; the enclosures converge quadratically with the cell's size, so a form strictly inside
its bounds is proven after a few. The form itself is evaluated at the corners and centre of
each cell left open: a point of the domain where it breaks a bound is a counterexample. A
condition still open at the last depth is refused too: the form comes within rounding of its
bound (a set whose ``k_b`` touches zero is not physical either).

The domain is the box of the set's ratio ranges, intersected with the convex hull of its data
when it has one: cells wholly outside the hull are dropped; cells across its edge are checked
whole (a superset: conservative).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from math import comb

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_DEPTH", "ROUNDING", "Bound", "Violation", "first_violation"]

#: Bernstein coefficients must exceed this times their magnitude (see the module docstring).
ROUNDING = 1e-11
#: Halvings of the domain's box per axis before an open condition is refused.
MAX_DEPTH = 12
#: Cells examined in all before an open condition is refused (bounds the time of a check).
MAX_CELLS = 4096


@dataclass(frozen=True)
class Bound:
    """One condition on a closed form: ``lo < P`` (``upper`` False) or ``P < hi`` (True).

    Attributes
    ----------
    exponents : tuple of (int, int)
        ``(p, q)`` per term, the powers of ``π1`` and ``π3``.
    coefficients : tuple of float
        ``c`` per term.
    limit : float
        ``lo`` or ``hi``.
    upper : bool
        Whether ``limit`` bounds the form from above.
    """

    exponents: tuple[tuple[int, int], ...]
    coefficients: tuple[float, ...]
    limit: float
    upper: bool


@dataclass(frozen=True)
class Violation:
    """Where a :class:`Bound` is not proven.

    Attributes
    ----------
    index : int
        The bound's position in the sequence given to :func:`first_violation`.
    h, s : float
        ``H/r_b`` and ``t/r_b`` of the point (a counterexample) or of the cell's centre.
    found : bool
        True: the form breaks the bound at ``(h, s)``, a point of the domain. False: the bound
        is not proven on a cell of the last depth around ``(h, s)`` (within rounding of it).
    """

    index: int
    h: float
    s: float
    found: bool


def first_violation(
    bounds: Sequence[Bound],
    h_range: tuple[float, float],
    s_range: tuple[float, float],
    hull: NDArray | None = None,
) -> Violation | None:
    """The first of ``bounds`` not proven over the domain, or None when all are.

    Parameters
    ----------
    bounds : sequence of Bound
    h_range, s_range : (float, float)
        The box of ``H/r_b`` and ``t/r_b``; both lower ends must be positive.
    hull : ndarray of shape (n, 2), optional
        Counter-clockwise vertices of a convex polygon in ``(H/r_b, t/r_b)`` that narrows the
        domain (at least 3).

    Returns
    -------
    Violation or None
        Of the lowest index among the bounds not proven (their order is the caller's).
    """
    if not (h_range[0] > 0.0 and s_range[0] > 0.0):
        raise ValueError("the domain's H/r_b and t/r_b must be positive")
    polys = _polynomials(bounds)
    cells = np.array([[h_range[0], h_range[1], s_range[0], s_range[1]]], dtype=float)
    cells = cells[_keep(cells, hull)]
    open_ = np.ones((len(cells), len(bounds)), dtype=bool)
    examined = 0
    for depth in range(MAX_DEPTH + 1):
        if not len(cells):
            return None
        examined += len(cells)
        proven, hints = _proven(polys, cells)
        open_ &= ~proven
        found = _counterexample(bounds, cells, open_, hints, hull)
        if found is not None:
            return found
        rows = np.flatnonzero(open_.any(axis=1))
        if not len(rows):
            return None
        if depth == MAX_DEPTH or examined + 4 * len(rows) > MAX_CELLS:
            return _unproven(cells[rows], open_[rows])
        cells, open_ = _split(cells[rows], open_[rows])
        keep = _keep(cells, hull)
        cells, open_ = cells[keep], open_[keep]
    return None  # pragma: no cover  (the loop returns at MAX_DEPTH)


def _unproven(cells: NDArray, open_: NDArray) -> Violation:
    index = int(np.flatnonzero(open_.any(axis=0))[0])
    h0, h1, s0, s1 = cells[np.flatnonzero(open_[:, index])[0]]
    return Violation(index, 0.5 * (h0 + h1), 0.5 * (s0 + s1), found=False)


# ---------------------------------------------------------------------- polynomials in (h, s)


def _polynomials(bounds: Sequence[Bound]) -> NDArray:
    """``F (P − lo)`` or ``F (hi − P)`` of each bound as coefficients ``A[h power, s power]``.

    Returns an array of shape ``(2, n_bounds, n_h, n_s)``: the coefficients, then their
    magnitudes (for the rounding bound), padded to the largest degrees.
    """
    built = []
    for bound in bounds:
        ps = [p for p, _ in bound.exponents] + [0]
        qs = [q for _, q in bound.exponents] + [0]
        a = max(0, -min(ps))
        b = max(0, max(p - 2 * q for p, q in zip(ps, qs, strict=True)))
        k = max(0, max(qs))
        sign = -1.0 if bound.upper else 1.0
        # the limit as a term of P: P − lo = (−lo) + P, hi − P = hi − P
        terms = [
            (p, q, sign * c) for (p, q), c in zip(bound.exponents, bound.coefficients, strict=True)
        ]
        terms.append((0, 0, -sign * bound.limit))
        entries: dict[tuple[int, int], list[float]] = {}
        for p, q, c in terms:
            # c 2^q s^(p+a) h^(2q−p+b) (1 + h²)^(k−q), expanded binomially
            for m in range(k - q + 1):
                key = (2 * q - p + b + 2 * m, p + a)
                entries.setdefault(key, []).append(c * 2.0**q * comb(k - q, m))
        built.append(entries)
    n_h = 1 + max(i for entries in built for i, _ in entries)
    n_s = 1 + max(j for entries in built for _, j in entries)
    polys = np.zeros((2, len(bounds), n_h, n_s))
    for n, entries in enumerate(built):
        for (i, j), values in entries.items():
            polys[0, n, i, j] = sum(values)
            polys[1, n, i, j] = sum(abs(v) for v in values)
    return polys


@lru_cache(maxsize=64)
def _binomials(n: int) -> tuple[NDArray, NDArray, NDArray]:
    """``C(j, k)`` at ``[k, j]``, ``max(j − k, 0)`` at ``[k, j]``, and ``C(i, k) / C(n, k)``."""
    j = np.arange(n + 1)
    binom = np.array([[comb(r, c) for c in range(n + 1)] for r in range(n + 1)], dtype=float)
    gap = np.clip(j[None, :] - j[:, None], 0, None)
    return binom.T, gap, binom / binom[n][None, :]


def _bernstein_matrices(lo: NDArray, hi: NDArray, degree: int) -> NDArray:
    """Per cell, the matrix from power coefficients to Bernstein coefficients on ``[lo, hi]``.

    ``x = lo + w u``: the power coefficients in ``u`` are ``T a`` with
    ``T[k, j] = C(j, k) lo^(j−k) w^k``, and the Bernstein coefficients of degree ``n`` are
    ``b_i = Σ_k C(i, k) / C(n, k) a'_k``. All entries are non-negative for ``lo, w >= 0``.
    """
    shift, gap, to_bernstein = _binomials(degree)
    k = np.arange(degree + 1)[None, :, None]
    T = shift[None] * lo[:, None, None] ** gap[None] * (hi - lo)[:, None, None] ** k
    return to_bernstein[None] @ T


def _proven(polys: NDArray, cells: NDArray) -> tuple[NDArray, NDArray]:
    """Per cell and bound, whether every Bernstein coefficient clears its rounding bound.

    Returns
    -------
    proven : ndarray of bool, shape (n_cells, n_bounds)
    hints : ndarray of shape (n_cells, n_bounds, 2)
        The control point ``(h, s)`` of each one's least coefficient (relative to its rounding
        bound): where a counterexample is likeliest.
    """
    n_h, n_s = polys.shape[2] - 1, polys.shape[3] - 1
    Lh = _bernstein_matrices(cells[:, 0], cells[:, 1], n_h)  # (cells, n_h+1, n_h+1)
    Ls = _bernstein_matrices(cells[:, 2], cells[:, 3], n_s)
    # B = Lh A Ls^T for the coefficients and their magnitudes: (2, cells, bounds, n_h+1, n_s+1)
    B = Lh[None, :, None] @ polys[:, None] @ np.swapaxes(Ls, 1, 2)[None, :, None]
    with np.errstate(invalid="ignore", over="ignore"):
        margin = B[0] - ROUNDING * B[1]
        proven = (margin > 0.0).all(axis=(2, 3))
    least = np.nan_to_num(margin, nan=-np.inf).reshape(*margin.shape[:2], -1).argmin(axis=2)
    i, j = np.divmod(least, n_s + 1)
    hints = np.stack(
        [
            cells[:, 0, None] + i / max(n_h, 1) * (cells[:, 1] - cells[:, 0])[:, None],
            cells[:, 2, None] + j / max(n_s, 1) * (cells[:, 3] - cells[:, 2])[:, None],
        ],
        axis=-1,
    )
    return proven, hints


def _split(cells: NDArray, open_: NDArray) -> tuple[NDArray, NDArray]:
    h0, h1, s0, s1 = cells.T
    hm, sm = 0.5 * (h0 + h1), 0.5 * (s0 + s1)
    quarters = [
        np.column_stack(c)
        for c in ((h0, hm, s0, sm), (hm, h1, s0, sm), (h0, hm, sm, s1), (hm, h1, sm, s1))
    ]
    return np.concatenate(quarters), np.concatenate([open_] * 4)


# ---------------------------------------------------------------------- the domain


def _half_planes(h: NDArray, s: NDArray, hull: NDArray) -> NDArray:
    """Per point (leading axes of ``h``, ``s``) and hull edge: inside that edge's half-plane.

    The inside of a counter-clockwise hull is on the left of every edge, to 1e-12 of the
    hull's size (as ``ConstantsSet.inside_hull`` decides it).
    """
    edges = np.roll(hull, -1, axis=0) - hull
    tol = 1e-12 * float(np.abs(hull).max()) * np.hypot(edges[:, 0], edges[:, 1])
    h, s = np.asarray(h)[..., None], np.asarray(s)[..., None]
    with np.errstate(invalid="ignore"):
        cross = edges[:, 0] * (s - hull[:, 1]) - edges[:, 1] * (h - hull[:, 0])
        return cross >= -tol


def _inside(h: NDArray, s: NDArray, hull: NDArray | None) -> NDArray:
    """Whether points lie in the hull (all finite points without one)."""
    inside = np.isfinite(h) & np.isfinite(s)
    return inside if hull is None else inside & _half_planes(h, s, hull).all(axis=-1)


def _keep(cells: NDArray, hull: NDArray | None) -> NDArray:
    """Cells not wholly outside the hull (outside one edge's half-plane at every corner)."""
    if hull is None:
        return np.ones(len(cells), dtype=bool)
    corners = _half_planes(cells[:, [0, 1, 0, 1]], cells[:, [2, 2, 3, 3]], hull)
    return ~np.any(~corners.any(axis=1), axis=1)


def _counterexample(
    bounds: Sequence[Bound],
    cells: NDArray,
    open_: NDArray,
    hints: NDArray,
    hull: NDArray | None,
) -> Violation | None:
    """A point of the domain where a bound breaks (a corner, centre or hint of an open cell)."""
    rows = np.flatnonzero(open_.any(axis=1))
    if not len(rows):
        return None
    h0, h1, s0, s1 = cells[rows].T
    h = np.concatenate([np.column_stack([0.5 * (h0 + h1), h0, h1, h0, h1]), hints[rows, :, 0]], 1)
    s = np.concatenate([np.column_stack([0.5 * (s0 + s1), s0, s0, s1, s1]), hints[rows, :, 1]], 1)
    h, s = h.ravel(), s.ravel()
    inside = _inside(h, s, hull)
    if not inside.any():
        return None
    h, s = h[inside], s[inside]
    R = (h * h + 1.0) / (2.0 * h)
    pi1, pi3 = (s / h)[:, None], (h / R)[:, None]
    for index, bound in enumerate(bounds):
        p, q = np.array(bound.exponents, dtype=float).reshape(-1, 2).T
        value = (np.array(bound.coefficients) * pi1**p * pi3**q).sum(axis=1)
        broken = ~(value < bound.limit) if bound.upper else ~(value > bound.limit)
        if broken.any():
            i = int(np.flatnonzero(broken)[0])
            return Violation(index, float(h[i]), float(s[i]), found=True)
    return None
