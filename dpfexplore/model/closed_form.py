"""Closed forms in ``π1 = t/H`` and ``π3 = H/R``, and their evaluation in NumPy and in kernels.

A :class:`ClosedForm` is a sum of monomials ``c · π1^p · π3^q``. A constants set
(:mod:`dpfexplore.model.constants_set`) holds three of them; the kernels that build the lattice
tables read a set as a record of two arrays (its terms' powers and coefficients) and evaluate
it with :func:`set_constants_form` and :func:`set_constant_partials`. Both paths form the same
products in the same order (powers by repeated multiplication, :func:`_ipow`), so they agree bit
for bit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba.extending import register_jitable
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "FORM_ALPHA",
    "FORM_K_HAT",
    "FORM_TIP_RATIO",
    "MAX_POWER",
    "ClosedForm",
    "ConstantsSetError",
    "power_tables",
    "set_constant_partials",
    "set_constants_form",
]

#: Largest power of ``π1`` or ``π3`` a closed form may hold (either sign): identification's
#: libraries go to degree 5.
MAX_POWER = 6
#: Rows of :meth:`ConstantsSet.kernel_forms`: the three closed forms.
FORM_K_HAT = 0
FORM_ALPHA = 1
FORM_TIP_RATIO = 2


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
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            total = total + _term(c, p, q, pi1, pi3)
        return total

    def partials(self, pi1: ArrayLike, pi3: ArrayLike) -> tuple[NDArray, NDArray]:
        """``∂/∂π1`` and ``∂/∂π3`` of the closed form at ``(π1, π3)``."""
        pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
        d1 = np.zeros(np.broadcast(pi1, pi3).shape)
        d3 = np.zeros_like(d1)
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            if p:
                d1 = d1 + _term(c * p, p - 1, q, pi1, pi3)
            if q:
                d3 = d3 + _term(c * q, p, q - 1, pi1, pi3)
        return d1, d3

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


@register_jitable
def _ipow(x, n):
    """``x**n`` for a small integer ``n`` by multiplication (identical in NumPy and Numba)."""
    result = 1.0 + 0.0 * x
    for _ in range(abs(n)):
        result = result * x
    if n < 0:
        return 1.0 / result
    return result


@register_jitable
def _term(c, p, q, pi1, pi3):
    """One monomial ``c π1^p π3^q`` (scalars in kernels, arrays in NumPy)."""
    return c * _ipow(pi1, p) * _ipow(pi3, q)


@register_jitable
def _power_table(x, out):
    """``out[k] = x**k`` for ``k = 0..MAX_POWER``, by the multiplications of :func:`_ipow`."""
    power = 1.0
    out[0] = power
    for k in range(1, MAX_POWER + 1):
        power = power * x
        out[k] = power


@register_jitable
def _form_value(forms, f, P1, P3):
    """Closed form ``f`` of a :meth:`ConstantsSet.kernel_forms` record from power tables.

    ``P1``, ``P3``: :func:`_power_table` of ``π1`` and ``π3``; a negative power is
    ``1 / x**|n|``, as :func:`_ipow` computes it. Each term is ``c · π1^p · π3^q`` with those
    powers, so the sum equals the NumPy :meth:`ClosedForm.__call__` bit for bit (padding terms
    ``0 · 1 · 1`` add zero); the tables only spare recomputing the powers per term. (The power
    lookups stay inline expressions: as a helper function they made the loop 5x slower.)
    """
    powers, coefficients = forms
    total = 0.0
    for j in range(coefficients.shape[1]):
        p = powers[f, j, 0]
        q = powers[f, j, 1]
        a = P1[p] if p >= 0 else 1.0 / P1[-p]
        b = P3[q] if q >= 0 else 1.0 / P3[-q]
        total = total + coefficients[f, j] * a * b
    return total


@register_jitable
def _form_partials(forms, f, P1, P3):
    """Closed form ``f`` and its partials ``∂/∂π1``, ``∂/∂π3`` from power tables."""
    powers, coefficients = forms
    value = 0.0
    d1 = 0.0
    d3 = 0.0
    for j in range(coefficients.shape[1]):
        c = coefficients[f, j]
        p = powers[f, j, 0]
        q = powers[f, j, 1]
        a = P1[p] if p >= 0 else 1.0 / P1[-p]
        b = P3[q] if q >= 0 else 1.0 / P3[-q]
        value = value + c * a * b
        if p != 0:
            a1 = P1[p - 1] if p >= 1 else 1.0 / P1[1 - p]
            d1 = d1 + c * p * a1 * b
        if q != 0:
            b1 = P3[q - 1] if q >= 1 else 1.0 / P3[1 - q]
            d3 = d3 + c * q * a * b1
    return value, d1, d3


@register_jitable
def power_tables():
    """Scratch of :func:`set_constants_form`: the powers of ``π1`` and ``π3``.

    Allocated once per batch by the kernels (an allocation per dome would cost more than the
    closed forms themselves).
    """
    return np.empty(MAX_POWER + 1), np.empty(MAX_POWER + 1)


@register_jitable
def set_constants_form(forms, E, H, t, r_b, powers):
    """``(k_b, alpha, tip_dis)`` of one dome under a set (N/mm, --, mm).

    The arithmetic of :meth:`ConstantsSet.evaluate` on scalars, for the kernels that build the
    lattice tables; ``forms`` is :meth:`ConstantsSet.kernel_forms`, ``powers`` a
    :func:`power_tables` scratch.
    """
    R = (H * H + r_b * r_b) / (2.0 * H)
    pi1 = t / H
    pi3 = H / R
    P1, P3 = powers
    _power_table(pi1, P1)
    _power_table(pi3, P3)
    k_b = E * (t * t) / R * _form_value(forms, FORM_K_HAT, P1, P3)
    alpha = _form_value(forms, FORM_ALPHA, P1, P3)
    tip = H * _form_value(forms, FORM_TIP_RATIO, P1, P3)
    return k_b, alpha, tip


@register_jitable
def set_constant_partials(forms, E, H, t, r_b, powers):
    """Derivatives of ``k_b``, ``alpha`` and ``tip_dis`` in ``H`` and ``t`` under a set.

    Returns ``(dkb_dH, dkb_dt, dalpha_dH, dalpha_dt, dtip_dH, dtip_dt)`` (units of the constant
    per mm): the chain rule through ``π1 = t/H``, ``π3 = H/R`` and ``R = (H² + r_b²)/(2H)``
    (MODEL.md §2-§3), exact for any set. ``powers``: a :func:`power_tables` scratch.
    """
    R = (H * H + r_b * r_b) / (2.0 * H)
    dR_dH = 0.5 - r_b * r_b / (2.0 * H * H)
    pi1 = t / H
    pi3 = H / R
    dpi1_dH = -t / (H * H)
    dpi1_dt = 1.0 / H
    dpi3_dH = (R - H * dR_dH) / (R * R)
    P1, P3 = powers
    _power_table(pi1, P1)
    _power_table(pi3, P3)
    k, k1, k3 = _form_partials(forms, FORM_K_HAT, P1, P3)
    _, a1, a3 = _form_partials(forms, FORM_ALPHA, P1, P3)
    g, g1, g3 = _form_partials(forms, FORM_TIP_RATIO, P1, P3)
    scale = E * (t * t) / R
    dkb_dH = scale * (k1 * dpi1_dH + k3 * dpi3_dH) - scale * k * dR_dH / R
    dkb_dt = 2.0 * E * t / R * k + scale * k1 * dpi1_dt
    dalpha_dH = a1 * dpi1_dH + a3 * dpi3_dH
    dalpha_dt = a1 * dpi1_dt
    dtip_dH = g + H * (g1 * dpi1_dH + g3 * dpi3_dH)
    dtip_dt = H * g1 * dpi1_dt
    return dkb_dH, dkb_dt, dalpha_dH, dalpha_dt, dtip_dH, dtip_dt


def _superscript(n: int) -> str:
    digits = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return "" if n == 1 else str(n).translate(digits)
