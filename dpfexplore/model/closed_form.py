"""Closed forms in ``π1 = t/H`` and ``π3 = H/R``, and their evaluation in NumPy and in kernels.

A :class:`ClosedForm` is a sum of monomials ``c · π1^p · π3^q``. A constants set
(:mod:`dpfexplore.model.constants_set`) holds one per row of
:data:`~dpfexplore.model.quantities.SET_FORMS`; the kernels that build the lattice
tables read a set as a record of two arrays (its terms' powers and coefficients), flatten it
once per batch (:func:`set_terms`) and evaluate it a block of domes at a time
(:func:`set_constants_block`): power tables per dome, then each term across the block. Both
paths form the same products in the same order (powers by repeated multiplication,
:class:`_Powers`; terms summed from zero in the form's order), so they agree bit for bit.
Working across a block lets the compiler vectorise over domes (``dpfexplore bench identify``
puts the cost beside the paper's forms compiled as plain arithmetic).
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba.extending import register_jitable
from numpy.typing import ArrayLike, NDArray

from .quantities import SCALE_HEIGHT, SCALE_STIFFNESS, SET_FORM_NAMES, SET_FORMS

__all__ = [
    "DOME_BLOCK",
    "FORM_ALPHA",
    "FORM_K_HAT",
    "FORM_TIP_RATIO",
    "MAX_POWER",
    "N_FORMS",
    "ClosedForm",
    "ConstantsSetError",
    "DomeBlock",
    "FormTerms",
    "block_size",
    "dome_block",
    "set_constants_block",
    "set_terms",
]

#: Largest power of ``π1`` or ``π3`` a closed form may hold (either sign): identification's
#: libraries go to degree 5.
MAX_POWER = 6
#: Rows of :meth:`ConstantsSet.kernel_forms` and of :attr:`DomeBlock.values`: one per closed form
#: of :data:`~dpfexplore.model.quantities.SET_FORMS`, in its order.
FORM_K_HAT = SET_FORM_NAMES.index("k_hat")
FORM_ALPHA = SET_FORM_NAMES.index("alpha")
FORM_TIP_RATIO = SET_FORM_NAMES.index("tip_ratio")
#: Closed forms of a set. :func:`set_terms` gives ``N_FORMS`` forms (rows ``FORM_*``), or with
#: ``partials`` also their derivatives in ``π1`` (rows ``N_FORMS + FORM_*``) and in ``π3``
#: (``2 N_FORMS + FORM_*``).
N_FORMS = len(SET_FORMS)
#: How each form gives its quantity (``SCALE_*`` of :mod:`.quantities`), by row.
FORM_SCALES = tuple(form.scale for form in SET_FORMS)


class ConstantsSetError(ValueError):
    """A constants set that cannot be read, does not match its fingerprint, or is unphysical."""


@dataclass(frozen=True)
class ClosedForm:
    """``Σ c_i π1^p_i π3^q_i`` over its terms.

    Attributes
    ----------
    exponents : tuple of (int, int)
        ``(p, q)`` per term: powers of ``π1 = t/H`` and ``π3 = H/R`` (may be negative).
    coefficients : tuple of float
        ``c`` per term.
    """

    exponents: tuple[tuple[int, int], ...]
    coefficients: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.exponents) != len(self.coefficients):
            raise ConstantsSetError(
                f"{len(self.exponents)} exponent pairs but {len(self.coefficients)} coefficients"
            )
        if len(set(self.exponents)) != len(self.exponents):
            raise ConstantsSetError(f"repeated exponent pairs in {self.exponents}")
        for p, q in self.exponents:
            if max(abs(p), abs(q)) > MAX_POWER:
                raise ConstantsSetError(
                    f"powers ({p}, {q}): each must lie in -{MAX_POWER}..{MAX_POWER}"
                )
        for c in self.coefficients:
            if not np.isfinite(c):
                raise ConstantsSetError(f"coefficient {c!r} is not a finite number")

    def __call__(self, pi1: ArrayLike, pi3: ArrayLike) -> NDArray:
        """The closed form at ``(π1, π3)`` (broadcasting)."""
        pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
        total = np.zeros(np.broadcast(pi1, pi3).shape)
        powers1, powers3 = _Powers(pi1), _Powers(pi3)
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            total = total + c * powers1[p] * powers3[q]
        return total

    def partials(self, pi1: ArrayLike, pi3: ArrayLike) -> tuple[NDArray, NDArray]:
        """``∂/∂π1`` and ``∂/∂π3`` of the closed form at ``(π1, π3)``."""
        pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
        d1 = np.zeros(np.broadcast(pi1, pi3).shape)
        d3 = np.zeros_like(d1)
        powers1, powers3 = _Powers(pi1), _Powers(pi3)
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            if p:
                d1 = d1 + c * p * powers1[p - 1] * powers3[q]
            if q:
                d3 = d3 + c * q * powers1[p] * powers3[q - 1]
        return d1, d3

    def at(self, powers1: Sequence[float], powers3: Sequence[float]) -> float:
        """The closed form at one point from its :func:`float_powers` (a Python float).

        The sum of :meth:`__call__` in plain floats: for one dome without NumPy's per-call cost.
        """
        total = 0.0
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            total = total + c * powers1[p + MAX_POWER] * powers3[q + MAX_POWER]
        return total

    def text(self, name: str) -> str:
        """The closed form written out, e.g. ``alpha = 0.3823 π3³ − 0.5736 π1³ + ...``."""
        parts = []
        for (p, q), c in sorted(zip(self.exponents, self.coefficients, strict=True)):
            factors = "·".join(f"{s}{_superscript(e)}" for s, e in (("π1", p), ("π3", q)) if e != 0)
            parts.append(f"{c:+.6g}" + (f" {factors}" if factors else ""))
        return f"{name} = " + " ".join(parts) if parts else f"{name} = 0"

    def to_dict(self) -> dict[str, Any]:
        """Plain mapping for JSON."""
        return {
            "terms": [
                {"pi1": p, "pi3": q, "coefficient": c}
                for (p, q), c in zip(self.exponents, self.coefficients, strict=True)
            ]
        }

    @classmethod
    def from_dict(cls, data: Any, where: str) -> ClosedForm:
        """Read :meth:`to_dict`'s mapping (one-line errors naming ``where``)."""
        if not isinstance(data, Mapping) or not isinstance(data.get("terms"), list):
            raise ConstantsSetError(f"{where}: need a table with a list of terms")
        exponents, coefficients = [], []
        for i, term in enumerate(data["terms"]):
            if not isinstance(term, Mapping):
                raise ConstantsSetError(f"{where}.terms[{i}]: need {{pi1, pi3, coefficient}}")
            try:
                p, q, c = term["pi1"], term["pi3"], term["coefficient"]
            except KeyError as exc:
                raise ConstantsSetError(f"{where}.terms[{i}]: missing {exc.args[0]}") from None
            if not all(isinstance(v, int) and not isinstance(v, bool) for v in (p, q)):
                raise ConstantsSetError(f"{where}.terms[{i}]: powers must be integers")
            if isinstance(c, bool) or not isinstance(c, int | float):
                raise ConstantsSetError(f"{where}.terms[{i}]: coefficient must be a number")
            exponents.append((p, q))
            coefficients.append(float(c))
        return cls(tuple(exponents), tuple(coefficients))


class _Powers:
    """``x^n`` of an array for integer ``n``, each formed once.

    ``x^k = x^(k-1) · x`` from ``x^0 = 1 + 0·x`` (NaN stays NaN), and ``x^-k = 1 / x^k``: the
    products of the kernels' power tables (:func:`_power_rows`), bit for bit.
    """

    def __init__(self, x: NDArray) -> None:
        self._x = x
        self._positive = [1.0 + 0.0 * x]

    def __getitem__(self, n: int) -> NDArray:
        while len(self._positive) <= abs(n):
            self._positive.append(self._positive[-1] * self._x)
        return self._positive[n] if n >= 0 else 1.0 / self._positive[-n]


def float_powers(x: float) -> list[float]:
    """``x^k`` for ``k = -MAX_POWER .. MAX_POWER`` at index ``k + MAX_POWER`` (floats).

    Formed as :class:`_Powers` forms them, for one dome's :meth:`ClosedForm.at`.
    """
    positive = [1.0 + 0.0 * x]
    for _ in range(MAX_POWER):
        positive.append(positive[-1] * x)
    return [1.0 / v for v in positive[:0:-1]] + positive


#: Row of the power ``π^0`` in a power table; a table holds the powers
#: ``-(MAX_POWER + 1) .. MAX_POWER + 1`` (the partials of a term in ``π^-MAX_POWER`` reach one
#: lower, and ``1 / π^k`` needs ``π^k``).
POWER_OFFSET = MAX_POWER + 1
POWER_TABLE_SIZE = 2 * MAX_POWER + 3
#: Rows of :attr:`DomeBlock.partials`: each form's quantity differentiated in ``H`` (row
#: ``2 FORM_*``) and in ``t`` (row ``2 FORM_* + 1``): ``∂k_b/∂H, ∂k_b/∂t, ∂α/∂H, ...`` (units of
#: the quantity per mm).
N_SET_PARTIALS = 2 * N_FORMS
#: Most domes a kernel evaluates together (at least ``MAX_UNITS``: one design's units share a
#: block). Larger blocks cost fewer passes of the gather, term and fill loops; on the benchmark
#: machine 384 built the tables about 15 % faster than 96, and 768 no faster than 384.
DOME_BLOCK = 384

#: A constants set's closed forms as one list of terms (:func:`set_terms`): per term its
#: ``coefficients`` and the rows ``index1``, ``index3`` (int64) of its powers of ``π1`` and
#: ``π3`` in a power table; ``ends`` (int64): where each form's terms end; ``range1``,
#: ``range3`` (int64, ``(2,)``): the lowest and highest powers of ``π1`` and ``π3`` in use.
FormTerms = namedtuple(
    "FormTerms", ["coefficients", "index1", "index3", "ends", "range1", "range3"]
)

#: A block of domes (:func:`dome_block`): their ``H``, ``t``, ``r_b`` (mm) and ``E`` (MPa), each
#: ``(DOME_BLOCK,)``, filled by the caller; the radii ``R`` (mm) and the power tables ``P1``,
#: ``P3`` ``(POWER_TABLE_SIZE, DOME_BLOCK)`` as scratch; and what :func:`set_constants_block`
#: writes: ``values`` ``(n_forms, DOME_BLOCK)`` (rows ``FORM_*`` end as the forms' quantities:
#: ``k_b`` (N/mm), ``alpha``, ``tip_dis`` (mm)) and ``partials`` ``(N_SET_PARTIALS, DOME_BLOCK)``.
DomeBlock = namedtuple("DomeBlock", ["H", "t", "r_b", "E", "R", "P1", "P3", "values", "partials"])


@register_jitable
def _used_terms(powers, coefficients, f):
    """Terms of form ``f`` up to its last one that is not padding (``0 · π1⁰ · π3⁰``)."""
    used = 0
    for j in range(coefficients.shape[1]):
        if coefficients[f, j] != 0.0 or powers[f, j, 0] != 0 or powers[f, j, 1] != 0:
            used = j + 1
    return used


@register_jitable
def set_terms(forms, partials):
    """The terms a kernel evaluates for a set: :meth:`ConstantsSet.kernel_forms` flattened.

    The closed forms, and with ``partials`` (bool) their derivatives in ``π1`` and ``π3``
    as closed forms of their own (``c p · π1^(p-1) π3^q`` per term with ``p != 0``, as
    :meth:`ClosedForm.partials` forms them). Trailing padding is dropped: a term ``0 · 1 · 1``
    adds ``+0`` to a sum that starts at ``+0``, which changes no sum. Built once per batch.
    """
    powers, coefficients = forms
    n_forms = 3 * N_FORMS if partials else N_FORMS
    used = np.zeros(N_FORMS, dtype=np.int64)
    size = 0
    for f in range(N_FORMS):
        used[f] = _used_terms(powers, coefficients, f)
        size += 3 * used[f]
    c = np.empty(size)
    index1 = np.empty(size, dtype=np.int64)
    index3 = np.empty(size, dtype=np.int64)
    ends = np.empty(n_forms, dtype=np.int64)
    range1 = np.zeros(2, dtype=np.int64)
    range3 = np.zeros(2, dtype=np.int64)
    s = 0
    for form in range(n_forms):
        f = form % N_FORMS
        along = form // N_FORMS  # 0: the form, 1: its derivative in π1, 2: in π3
        for j in range(used[f]):
            coefficient = coefficients[f, j]
            p = powers[f, j, 0]
            q = powers[f, j, 1]
            if along == 1:
                if p == 0:
                    continue
                coefficient = coefficient * p
                p = p - 1
            elif along == 2:
                if q == 0:
                    continue
                coefficient = coefficient * q
                q = q - 1
            c[s] = coefficient
            index1[s] = p + POWER_OFFSET
            index3[s] = q + POWER_OFFSET
            range1[0] = min(range1[0], p)
            range1[1] = max(range1[1], p)
            range3[0] = min(range3[0], q)
            range3[1] = max(range3[1], q)
            s += 1
        ends[form] = s
    return FormTerms(c[:s], index1[:s], index3[:s], ends, range1, range3)


@register_jitable
def dome_block(terms, size):
    """A :data:`DomeBlock` of ``size`` domes for ``terms`` (allocated once per batch).

    ``size``: at most :data:`DOME_BLOCK`; what a batch needs (:func:`block_size`), so a single
    design allocates a block of its own size.
    """
    return DomeBlock(
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty((POWER_TABLE_SIZE, size)),
        np.empty((POWER_TABLE_SIZE, size)),
        np.empty((terms.ends.shape[0], size)),
        np.empty((N_SET_PARTIALS, size)),
    )


@register_jitable
def block_size(n_domes, least):
    """The block for ``n_domes`` domes: ``n_domes`` up to :data:`DOME_BLOCK`, at least ``least``."""
    return min(DOME_BLOCK, max(n_domes, least))


@register_jitable
def _power_rows(P, power_range, n):
    """Fill rows ``π^lo .. π^hi`` of table ``P`` whose row ``π^1`` holds ``π`` (domes ``< n``).

    ``π^k`` by repeated multiplication and ``π^-k = 1 / π^k``, as :class:`_Powers` forms them:
    each entry is the number the NumPy path forms.
    """
    lo = power_range[0]
    hi = power_range[1]
    x = P[POWER_OFFSET + 1]
    ones = P[POWER_OFFSET]
    for d in range(n):
        ones[d] = 1.0
    previous = x
    for k in range(2, max(hi, -lo) + 1):
        row = P[POWER_OFFSET + k]
        for d in range(n):
            row[d] = previous[d] * x[d]
        previous = row
    for k in range(1, -lo + 1):
        row = P[POWER_OFFSET - k]
        positive = P[POWER_OFFSET + k]
        for d in range(n):
            row[d] = 1.0 / positive[d]


@register_jitable
def _evaluate_block(terms, block, n):
    """Every form of ``terms`` at the first ``n`` domes of ``block`` into ``block.values``.

    Term by term across the domes: the loops over domes do the same operations in the same
    order for every dome, so the compiler vectorises them without changing a result.
    """
    coefficients, index1, index3, ends, range1, range3 = terms
    H, t, r_b = block.H, block.t, block.r_b
    R, P1, P3, values = block.R, block.P1, block.P3, block.values
    pi1 = P1[POWER_OFFSET + 1]
    pi3 = P3[POWER_OFFSET + 1]
    for d in range(n):
        Hd = H[d]
        Rd = (Hd * Hd + r_b[d] * r_b[d]) / (2.0 * Hd)
        R[d] = Rd
        pi1[d] = t[d] / Hd
        pi3[d] = Hd / Rd
    _power_rows(P1, range1, n)
    _power_rows(P3, range3, n)
    start = 0
    for f in range(ends.shape[0]):
        total = values[f]
        for d in range(n):
            total[d] = 0.0
        j = start
        # Four terms per pass over the block: a quarter of the loads and stores of the running
        # sums; each dome still adds its terms one at a time in the form's order.
        while j + 4 <= ends[f]:
            c0, c1, c2, c3 = (
                coefficients[j],
                coefficients[j + 1],
                coefficients[j + 2],
                coefficients[j + 3],
            )
            a0, a1, a2, a3 = P1[index1[j]], P1[index1[j + 1]], P1[index1[j + 2]], P1[index1[j + 3]]
            b0, b1, b2, b3 = P3[index3[j]], P3[index3[j + 1]], P3[index3[j + 2]], P3[index3[j + 3]]
            for d in range(n):
                s = total[d] + c0 * a0[d] * b0[d]
                s = s + c1 * a1[d] * b1[d]
                s = s + c2 * a2[d] * b2[d]
                total[d] = s + c3 * a3[d] * b3[d]
            j += 4
        while j < ends[f]:
            c = coefficients[j]
            a = P1[index1[j]]
            b = P3[index3[j]]
            for d in range(n):
                total[d] = total[d] + c * a[d] * b[d]
            j += 1
        start = ends[f]


@register_jitable
def set_constants_block(terms, block, n):
    """The forms' quantities (and their partials) of the first ``n`` domes of a block.

    ``terms``: :func:`set_terms` of the set; ``block``: a :data:`DomeBlock` whose ``H``, ``t``,
    ``r_b``, ``E`` hold the domes. Writes ``block.values`` rows ``FORM_*`` as each form's
    quantity, scaled as its row of :data:`~dpfexplore.model.quantities.SET_FORMS` says:
    ``k_b = E t²/R · k̂`` (N/mm), ``alpha`` and ``tip_dis = H · tip/H`` (mm), the arithmetic of
    :meth:`ConstantsSet.evaluate` (:func:`~dpfexplore.model.quantities.scaled`), bit for bit.
    When ``terms`` holds the partials, also ``block.partials``: the chain rule through
    ``π1 = t/H``, ``π3 = H/R`` and ``R = (H² + r_b²)/(2H)`` (MODEL.md §2-§3), exact for any set.
    """
    _evaluate_block(terms, block, n)
    H, t, r_b, E, R, values = block.H, block.t, block.r_b, block.E, block.R, block.values
    if terms.ends.shape[0] > N_FORMS:
        dk = block.partials
        for d in range(n):
            Hd = H[d]
            td = t[d]
            Rd = R[d]
            dR_dH = 0.5 - r_b[d] * r_b[d] / (2.0 * Hd * Hd)
            dpi1_dH = -td / (Hd * Hd)
            dpi1_dt = 1.0 / Hd
            dpi3_dH = (Rd - Hd * dR_dH) / (Rd * Rd)
            for f in range(N_FORMS):
                v = values[f, d]
                v1 = values[N_FORMS + f, d]
                v3 = values[2 * N_FORMS + f, d]
                scale = FORM_SCALES[f]
                if scale == SCALE_STIFFNESS:
                    s = E[d] * (td * td) / Rd
                    dk[2 * f, d] = s * (v1 * dpi1_dH + v3 * dpi3_dH) - s * v * dR_dH / Rd
                    dk[2 * f + 1, d] = 2.0 * E[d] * td / Rd * v + s * v1 * dpi1_dt
                elif scale == SCALE_HEIGHT:
                    dk[2 * f, d] = v + Hd * (v1 * dpi1_dH + v3 * dpi3_dH)
                    dk[2 * f + 1, d] = Hd * v1 * dpi1_dt
                else:
                    dk[2 * f, d] = v1 * dpi1_dH + v3 * dpi3_dH
                    dk[2 * f + 1, d] = v1 * dpi1_dt
    for f in range(N_FORMS):
        scale = FORM_SCALES[f]
        row = values[f]
        if scale == SCALE_STIFFNESS:
            for d in range(n):
                row[d] = E[d] * (t[d] * t[d]) / R[d] * row[d]
        elif scale == SCALE_HEIGHT:
            for d in range(n):
                row[d] = H[d] * row[d]


def _superscript(n: int) -> str:
    digits = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return "" if n == 1 else str(n).translate(digits)
