"""Closed forms in ``π1 = t/H`` and ``π3 = H/R``, and their evaluation in NumPy.

A :class:`ClosedForm` is a sum of monomials ``c · π1^p · π3^q``. A constants set
(:mod:`dpfexplore.model.constants_set`) holds one per row of
:data:`~dpfexplore.model.quantities.SET_FORMS`. The kernels that build the lattice tables
evaluate a set a block of domes at a time (:mod:`dpfexplore._kernels.tables.set_forms`); both
paths form the same products in the same order (powers by repeated multiplication,
:class:`_Powers`; terms summed from zero in the form's order), so they agree bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .quantities import SET_FORM_NAMES, SET_FORMS

__all__ = [
    "FORM_ALPHA",
    "FORM_K_HAT",
    "FORM_TIP_RATIO",
    "MAX_POWER",
    "N_FORMS",
    "ClosedForm",
    "ConstantsSetError",
]

#: Largest power of ``π1`` or ``π3`` a closed form may hold (either sign): identification's
#: libraries go to degree 5.
MAX_POWER = 6
#: Rows of :meth:`ConstantsSet.kernel_forms` (and of the kernels' ``DomeBlock.values``): one per
#: closed form of :data:`~dpfexplore.model.quantities.SET_FORMS`, in its order.
FORM_K_HAT = SET_FORM_NAMES.index("k_hat")
FORM_ALPHA = SET_FORM_NAMES.index("alpha")
FORM_TIP_RATIO = SET_FORM_NAMES.index("tip_ratio")
#: Closed forms of a set (the kernels' ``set_terms`` gives ``N_FORMS`` forms, rows ``FORM_*``,
#: or with ``partials`` also their derivatives in ``π1``, rows ``N_FORMS + FORM_*``, and in
#: ``π3``, ``2 N_FORMS + FORM_*``).
N_FORMS = len(SET_FORMS)


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
    products of the kernels' power tables (``_power_rows`` of
    :mod:`dpfexplore._kernels.tables.set_forms`), bit for bit.
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


def _superscript(n: int) -> str:
    digits = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return "" if n == 1 else str(n).translate(digits)
