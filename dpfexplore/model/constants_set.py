"""Constants sets: the closed forms of a dome's spring constants as data (MODEL.md §3, §11).

A constants set holds three closed forms in the dimensionless groups ``π1 = t/H`` and
``π3 = H/R`` (``π2 = t/R = π1 π3`` adds no column, MODEL.md §11), each a sum of monomials
``c · π1^p · π3^q``:

* ``k_hat = k_b R / (E t²)``, so ``k_b = E t² / R · k_hat``, N/mm;
* ``alpha``, the dome's energy ratio (dimensionless);
* ``tip_ratio = tip_dis / H``, the inverted apex travel per dome height, from which the reach
  follows as ``d = tip_dis − H − U_sep − t_ch/2 − t/2`` (MODEL.md §3).

It also records the domain it was fitted on (ranges of ``H/r_b``, ``t/r_b``, ``E``, ``nu``), its
provenance (how it was made, from what data) and a fingerprint: the SHA-256 of its canonical
JSON without the fingerprint. :func:`load_constants_set` refuses a file whose fingerprint does not
match its contents, and a set whose own closed forms give ``k_b <= 0`` or ``alpha`` outside
``(0, 1)`` inside its claimed domain (:meth:`ConstantsSet.check`).

:data:`DEFAULT` is the paper's closed forms (the implementation's digits) written as such a set;
:meth:`ConstantsSet.evaluate` reproduces :func:`~dpfexplore.model.constants.dome_stiffness`,
:func:`~dpfexplore.model.constants.dome_alpha` and the unclamped reach to rounding (tested below
1e-13 relative). The lattice kernels still evaluate the default closed forms compiled in
(:mod:`dpfexplore.model.constants`); running them on another set is not wired yet.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .constants import _ALPHA_TERMS, _KB_TERMS, TIP_PER_HEIGHT, TIP_PER_THICKNESS

__all__ = [
    "CONSTANTS_FORMAT",
    "DEFAULT",
    "ClosedForm",
    "ConstantsSet",
    "ConstantsSetError",
    "load_constants_set",
]

#: Identifies the file layout; bump when it changes incompatibly.
CONSTANTS_FORMAT = "dpfexplore-constants/1"
#: Points per axis of the grid on which :meth:`ConstantsSet.check` evaluates a set's domain.
CHECK_GRID = 41


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
        for c in self.coefficients:
            if not np.isfinite(c):
                raise ConstantsSetError(f"coefficient {c!r} is not a finite number")

    def __call__(self, pi1: ArrayLike, pi3: ArrayLike) -> NDArray:
        """The closed form at ``(π1, π3)`` (broadcasting)."""
        pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
        total = np.zeros(np.broadcast(pi1, pi3).shape)
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            total = total + c * _ipow(pi1, p) * _ipow(pi3, q)
        return total

    def partials(self, pi1: ArrayLike, pi3: ArrayLike) -> tuple[NDArray, NDArray]:
        """``∂/∂π1`` and ``∂/∂π3`` of the closed form at ``(π1, π3)``."""
        pi1, pi3 = np.asarray(pi1, dtype=float), np.asarray(pi3, dtype=float)
        d1 = np.zeros(np.broadcast(pi1, pi3).shape)
        d3 = np.zeros_like(d1)
        for (p, q), c in zip(self.exponents, self.coefficients, strict=True):
            if p:
                d1 = d1 + c * p * _ipow(pi1, p - 1) * _ipow(pi3, q)
            if q:
                d3 = d3 + c * q * _ipow(pi1, p) * _ipow(pi3, q - 1)
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


def _ipow(x: NDArray, n: int) -> NDArray:
    """``x**n`` for a small integer ``n`` by multiplication (as the compiled closed forms)."""
    result = np.ones_like(x)
    for _ in range(abs(n)):
        result = result * x
    return 1.0 / result if n < 0 else result


def _superscript(n: int) -> str:
    digits = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return "" if n == 1 else str(n).translate(digits)


@dataclass(frozen=True)
class ConstantsSet:
    """The closed forms for ``k_b``, ``alpha`` and the reach, their domain and provenance.

    Attributes
    ----------
    name : str
    k_hat, alpha, tip_ratio : ClosedForm
        ``k_b R / (E t²)``, ``alpha`` and ``tip_dis / H`` in ``π1 = t/H``, ``π3 = H/R``.
    domain : dict
        ``{"H_over_rb": [lo, hi], "t_over_rb": [lo, hi], "E": [lo, hi], "nu": [lo, hi]}``:
        where the forms were fitted (MPa for ``E``).
    provenance : dict
        How the set was made (method, settings, data checksum, package versions).
    """

    name: str
    k_hat: ClosedForm
    alpha: ClosedForm
    tip_ratio: ClosedForm
    domain: dict[str, tuple[float, float]]
    provenance: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ evaluation

    def evaluate(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, E: ArrayLike
    ) -> dict[str, NDArray]:
        """``k_b`` (N/mm), ``alpha`` and ``tip_dis`` (mm) of domes ``H, t, r_b`` (mm), ``E``.

        ``E`` in MPa; all arguments broadcast.
        """
        H, t, r_b, E = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (H, t, r_b, E)))
        R = (H * H + r_b * r_b) / (2.0 * H)
        pi1, pi3 = t / H, H / R
        return {
            "k_b": E * (t * t) / R * self.k_hat(pi1, pi3),
            "alpha": self.alpha(pi1, pi3),
            "tip_dis": H * self.tip_ratio(pi1, pi3),
        }

    def reach(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, U_sep: ArrayLike, t_ch: ArrayLike
    ) -> NDArray:
        """The unclamped reach ``d = tip_dis − H − U_sep − t_ch/2 − t/2`` (mm, MODEL.md §3)."""
        tip = self.evaluate(H, t, r_b, 1.0)["tip_dis"]
        return (
            tip - np.asarray(H) - np.asarray(U_sep) - np.asarray(t_ch) / 2.0 - np.asarray(t) / 2.0
        )

    def in_domain(self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, E: ArrayLike) -> NDArray:
        """Whether each dome lies in the set's fitted domain."""
        H, t, r_b, E = (np.asarray(a, dtype=float) for a in (H, t, r_b, E))
        checks = (("H_over_rb", H / r_b), ("t_over_rb", t / r_b), ("E", E))
        inside = np.ones(np.broadcast(H, t, r_b, E).shape, dtype=bool)
        for key, value in checks:
            lo, hi = self.domain[key]
            inside &= (value >= lo * (1 - 1e-12)) & (value <= hi * (1 + 1e-12))
        return inside

    def check(self) -> None:
        """Refuse a set whose forms are unphysical inside its own domain.

        Evaluated on a :data:`CHECK_GRID` × :data:`CHECK_GRID` grid of ``(H/r_b, t/r_b)`` over
        the domain (``k_b`` scales with ``E``, so one ``E`` suffices).

        Raises
        ------
        ConstantsSetError
            Naming the first dome where ``k_b <= 0``, ``alpha`` is outside ``(0, 1)`` or
            ``tip_dis <= H``.
        """
        h = np.linspace(*self.domain["H_over_rb"], CHECK_GRID)
        s = np.linspace(*self.domain["t_over_rb"], CHECK_GRID)
        H, t = np.meshgrid(h, s, indexing="ij")
        values = self.evaluate(H, t, 1.0, 1.0)
        problems = (
            (values["k_b"] <= 0.0, "k_b <= 0"),
            ((values["alpha"] <= 0.0) | (values["alpha"] >= 1.0), "alpha outside (0, 1)"),
            (values["tip_dis"] <= H, "tip_dis <= H (the inverted apex would not pass flat)"),
        )
        for bad, what in problems:
            if np.any(bad):
                i, j = np.argwhere(bad)[0]
                raise ConstantsSetError(
                    f"constants set {self.name!r}: {what} inside its own domain, at "
                    f"H/r_b = {H[i, j]:.4g}, t/r_b = {t[i, j]:.4g}"
                )

    # ------------------------------------------------------------------ files

    def to_dict(self) -> dict[str, Any]:
        """The set as JSON-ready data, with its fingerprint."""
        body = self._body()
        return {**body, "fingerprint": _fingerprint(body)}

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the set's canonical JSON (without the fingerprint itself)."""
        return _fingerprint(self._body())

    def _body(self) -> dict[str, Any]:
        return {
            "format": CONSTANTS_FORMAT,
            "name": self.name,
            "k_hat": self.k_hat.to_dict(),
            "alpha": self.alpha.to_dict(),
            "tip_ratio": self.tip_ratio.to_dict(),
            "domain": {k: list(v) for k, v in self.domain.items()},
            "provenance": self.provenance,
        }

    def save(self, path: str | Path) -> Path:
        """Write the set as JSON (atomically) and return the path."""
        from .files import atomic_write

        path = Path(path)
        atomic_write(path, json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")
        return path

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "constants set") -> ConstantsSet:
        """Read :meth:`to_dict`'s data; the fingerprint must match and the set be physical."""
        if not isinstance(data, Mapping):
            raise ConstantsSetError(f"{source}: not a constants set (a JSON object)")
        if data.get("format") != CONSTANTS_FORMAT:
            raise ConstantsSetError(
                f"{source}: format {data.get('format')!r}, expected {CONSTANTS_FORMAT!r}"
            )
        for key in ("name", "k_hat", "alpha", "tip_ratio", "domain", "fingerprint"):
            if key not in data:
                raise ConstantsSetError(f"{source}: missing {key!r}")
        body = {k: v for k, v in data.items() if k != "fingerprint"}
        if _fingerprint(body) != data["fingerprint"]:
            raise ConstantsSetError(
                f"{source}: its contents do not match its fingerprint (edited or damaged)"
            )
        domain = {}
        for key in ("H_over_rb", "t_over_rb", "E", "nu"):
            value = data["domain"].get(key) if isinstance(data["domain"], Mapping) else None
            if (
                not isinstance(value, list)
                or len(value) != 2
                or not all(isinstance(v, int | float) and np.isfinite(v) for v in value)
                or not value[0] <= value[1]
            ):
                raise ConstantsSetError(f"{source}: domain.{key} must be [low, high]")
            domain[key] = (float(value[0]), float(value[1]))
        result = cls(
            name=str(data["name"]),
            k_hat=ClosedForm.from_dict(data["k_hat"], f"{source}: k_hat"),
            alpha=ClosedForm.from_dict(data["alpha"], f"{source}: alpha"),
            tip_ratio=ClosedForm.from_dict(data["tip_ratio"], f"{source}: tip_ratio"),
            domain=domain,
            provenance=dict(data.get("provenance") or {}),
        )
        result.check()
        return result


def _fingerprint(body: Mapping[str, Any]) -> str:
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(canonical.encode()).hexdigest()


def load_constants_set(path: str | Path) -> ConstantsSet:
    """Read a constants set file (a JSON file written by :meth:`ConstantsSet.save`).

    Raises
    ------
    ConstantsSetError
        One line naming the file: unreadable, not JSON, another format, a fingerprint that does
        not match, or closed forms that are unphysical inside their own domain.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise ConstantsSetError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConstantsSetError(f"{path}: not a constants set (not JSON: {exc})") from None
    return ConstantsSet.from_dict(data, source=str(path))


def _paper_form(terms: Sequence[tuple[float, int, int, int]], *, kb: bool) -> ClosedForm:
    """The compiled closed form's terms ``c H^a t^b R^e`` as monomials of ``π1``, ``π3``.

    ``k_b = E/R² Σ c H^a t^b R^e = E t²/R Σ c π1^(b−2) π3^(a+b−2)``;
    ``alpha = Σ c H^a t^b R^e = Σ c π1^b π3^(a+b)`` (each term is dimensionless:
    ``a + b + e = 0``, resp. ``= 1`` for ``k_b``'s ``R``-weighted terms).
    """
    exponents, coefficients = [], []
    for c, a, b, e in terms:
        p = b - 2 if kb else b
        q = a + p
        if (kb and 1 - q != e) or (not kb and -q != e):
            raise AssertionError(f"term {(c, a, b, e)} is not a monomial of π1, π3")
        exponents.append((p, q))
        coefficients.append(c)
    return ClosedForm(tuple(exponents), tuple(coefficients))


#: The paper's closed forms (implementation's digits, MODEL.md §3) as a constants set. Domain:
#: the fitted ranges H 3-5 mm, t 0.5-1 mm at r_b = 5 mm, E 5-40 MPa, the paper's nu = 0.35.
DEFAULT = ConstantsSet(
    name="paper",
    k_hat=_paper_form(_KB_TERMS, kb=True),
    alpha=_paper_form(_ALPHA_TERMS, kb=False),
    tip_ratio=ClosedForm(((0, 0), (1, 0)), (TIP_PER_HEIGHT, TIP_PER_THICKNESS)),
    domain={"H_over_rb": (0.6, 1.0), "t_over_rb": (0.1, 0.2), "E": (5.0, 40.0), "nu": (0.35, 0.35)},
    provenance={
        "method": "the paper's regressions (eq. kb_model, alpha_model, d_model) with the "
        "coefficients of the authors' implementation",
        "source": "Osorio et al., SI 'Parameter Tuning'; MODEL.md §3",
    },
)
