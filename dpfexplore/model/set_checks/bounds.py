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
    polys, terms = _polynomials(bounds), _Terms(bounds)
    edges = None if hull is None else _Edges(np.asarray(hull, dtype=float))
    cells = np.array([[h_range[0], h_range[1], s_range[0], s_range[1]]], dtype=float)
    cells = cells[_keep(cells, edges)]
    open_ = np.ones((len(cells), len(bounds)), dtype=bool)
    examined = 0
    for depth in range(MAX_DEPTH + 1):
        if not len(cells):
            return None
        examined += len(cells)
        proven, hints = _proven(polys, cells)
        open_ &= ~proven
        rows = np.flatnonzero(open_.any(axis=1))
        if not len(rows):
            return None
        found = _counterexample(terms, cells[rows], hints[rows], edges)
        if found is not None:
            return found
        if depth == MAX_DEPTH or examined + 4 * len(rows) > MAX_CELLS:
            return _unproven(cells[rows], open_[rows])
        cells, open_ = _split(cells[rows], open_[rows])
        keep = _keep(cells, edges)
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
    forms = {}  # one expansion per distinct form: F P, |terms of F P| and F
    for bound in bounds:
        key = (bound.exponents, bound.coefficients)
        if key not in forms:
            forms[key] = _expand(*key)
    n_h = max(f.shape[1] for f in forms.values())
    n_s = max(f.shape[2] for f in forms.values())
    polys = np.zeros((2, len(bounds), n_h, n_s))
    for n, bound in enumerate(bounds):
        fp, fp_abs, f = forms[(bound.exponents, bound.coefficients)]
        sign = -1.0 if bound.upper else 1.0
        rows, cols = fp.shape
        # lower: F P − lo F; upper: hi F − F P
        polys[0, n, :rows, :cols] = sign * fp - sign * bound.limit * f
        polys[1, n, :rows, :cols] = fp_abs + abs(bound.limit) * f
    return polys


def _expand(exponents: tuple[tuple[int, int], ...], coefficients: tuple[float, ...]) -> NDArray:
    """``F P``, its terms' magnitudes and ``F`` of one form, as ``(3, n_h, n_s)`` coefficients.

    Each term ``c π1^p π3^q`` times ``F = s^a h^b (1 + h²)^k`` is
    ``c 2^q s^(p+a) h^(2q−p+b) (1 + h²)^(k−q)``, expanded binomially.
    """
    ps = [p for p, _ in exponents] + [0]
    qs = [q for _, q in exponents] + [0]
    a = max(0, -min(ps))
    b = max(0, max(p - 2 * q for p, q in zip(ps, qs, strict=True)))
    k = max(0, max(qs))
    n_h = 1 + max(2 * k - p + b for p in ps)
    out = np.zeros((3, n_h, 1 + max(ps) + a))
    for (p, q), c in zip([*exponents, (0, 0)], [*coefficients, None], strict=True):
        for m in range(k - q + 1):
            weight = 2.0**q * comb(k - q, m)
            i, j = 2 * q - p + b + 2 * m, p + a
            if c is None:  # F itself: the term (0, 0) with coefficient 1
                out[2, i, j] += weight
            else:
                out[0, i, j] += c * weight
                out[1, i, j] += abs(c) * weight
    return out


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


class _Edges:
    """A counter-clockwise hull's edges, for half-plane tests (as ``inside_hull`` makes them)."""

    def __init__(self, hull: NDArray) -> None:
        self.start = hull
        self.direction = np.roll(hull, -1, axis=0) - hull
        self.tol = (
            1e-12 * float(np.abs(hull).max()) * np.hypot(*self.direction.T)  # of the hull's size
        )

    def inside(self, h: NDArray, s: NDArray) -> NDArray:
        """Per point (the shape of ``h``, ``s``) and edge: on the inner side of that edge."""
        d, o = self.direction, self.start
        with np.errstate(invalid="ignore"):
            cross = d[:, 0] * (s[..., None] - o[:, 1]) - d[:, 1] * (h[..., None] - o[:, 0])
            return cross >= -self.tol


def _keep(cells: NDArray, edges: _Edges | None) -> NDArray:
    """Cells not wholly outside the hull (outside one edge's half-plane at every corner)."""
    if edges is None:
        return np.ones(len(cells), dtype=bool)
    corners = edges.inside(cells[:, [0, 1, 0, 1]], cells[:, [2, 2, 3, 3]])
    return ~np.any(~corners.any(axis=1), axis=1)


class _Terms:
    """The bounds' terms padded to one table, to evaluate every bound at many points at once."""

    def __init__(self, bounds: Sequence[Bound]) -> None:
        width = max(1, *(len(b.coefficients) for b in bounds))
        self.p = np.zeros((len(bounds), width))
        self.q = np.zeros((len(bounds), width))
        self.c = np.zeros((len(bounds), width))
        for n, bound in enumerate(bounds):
            for j, ((p, q), c) in enumerate(zip(bound.exponents, bound.coefficients, strict=True)):
                self.p[n, j], self.q[n, j], self.c[n, j] = p, q, c
        self.limit = np.array([b.limit for b in bounds])
        self.upper = np.array([b.upper for b in bounds])

    def broken(self, h: NDArray, s: NDArray) -> NDArray:
        """``(n_points, n_bounds)``: where each bound fails (NaN fails)."""
        R = (h * h + 1.0) / (2.0 * h)
        pi1, pi3 = (s / h)[:, None, None], (h / R)[:, None, None]
        with np.errstate(all="ignore"):
            value = (self.c * pi1**self.p * pi3**self.q).sum(axis=2)
            return np.where(self.upper, ~(value < self.limit), ~(value > self.limit))


def _counterexample(
    terms: _Terms, cells: NDArray, hints: NDArray, edges: _Edges | None
) -> Violation | None:
    """A point of the domain where a bound breaks (a corner, centre or hint of a cell)."""
    h0, h1, s0, s1 = cells.T
    h = np.concatenate([np.column_stack([0.5 * (h0 + h1), h0, h1, h0, h1]), hints[..., 0]], 1)
    s = np.concatenate([np.column_stack([0.5 * (s0 + s1), s0, s0, s1, s1]), hints[..., 1]], 1)
    h, s = h.ravel(), s.ravel()
    if edges is not None:
        inside = edges.inside(h, s).all(axis=1)
        h, s = h[inside], s[inside]
    if not len(h):
        return None
    broken = terms.broken(h, s)
    if not broken.any():
        return None
    index = int(np.flatnonzero(broken.any(axis=0))[0])
    i = int(np.flatnonzero(broken[:, index])[0])
    return Violation(index, float(h[i]), float(s[i]), found=True)
