"""Constants sets: the closed forms of a dome's spring constants as data (MODEL.md §3, §11).

A constants set holds one closed form per row of :data:`~dpfexplore.model.quantities.SET_FORMS`,
in the dimensionless groups ``π1 = t/H`` and ``π3 = H/R`` (``π2 = t/R = π1 π3`` adds no column,
MODEL.md §11), each a sum of monomials ``c · π1^p · π3^q``:

* ``k_hat = k_b R / (E t²)``, so ``k_b = E t² / R · k_hat``, N/mm;
* ``alpha``, the dome's energy ratio (dimensionless);
* ``tip_ratio = tip_dis / H``, the inverted apex travel per dome height, from which the reach
  follows as ``d = tip_dis − H − U_sep − t_ch/2 − t/2`` (MODEL.md §3).

It also records the domain it was fitted on (ranges of ``H/r_b``, ``t/r_b``, ``E``, ``nu``), its
provenance (how it was made, from what data) and a fingerprint: the SHA-256 of its canonical
JSON without the fingerprint (and without a verdict, :attr:`ConstantsSet.validation`).
:func:`load_constants_set` refuses a file whose fingerprint does not match its contents, and a
set whose forms are unphysical inside its claimed domain (:meth:`ConstantsSet.check`).

:data:`DEFAULT` is the paper's closed forms (the implementation's digits) written as such a set;
:meth:`ConstantsSet.evaluate` reproduces :func:`~dpfexplore.model.constants.dome_stiffness`,
:func:`~dpfexplore.model.constants.dome_alpha` and the unclamped reach to rounding (tested below
1e-13 relative), and so does the compiled path that every command runs on: the kernels read a
set as a record of two arrays (:meth:`ConstantsSet.kernel_forms`: each term's powers and
coefficient) and evaluate it with :mod:`dpfexplore.model.closed_form`, the same arithmetic in
the same order as the NumPy methods, so both agree bit for bit. No set is special: the paper's
is just the default.

Domain
    A set's domain is a table of ranges, each optional: ``H``, ``t``, ``r_b`` (mm), ``E``
    (MPa), ``nu``, ``H_over_rb`` and ``t_over_rb``. A dome is inside when it satisfies every
    range the set states. The paper's set states the ranges of its fit in mm (``H`` 3-5,
    ``t`` 0.5-1, ``r_b`` 5, ``E`` 5-40: :data:`dpfexplore.model.domain.FITTED_RANGES`); it
    states no ``nu`` range, since the paper's flag never covered ``nu`` (the regressions were
    fitted at 0.35 only). Sets identified from unit-cell curves state the dimensionless ranges
    of their data and its ``E`` and ``nu`` ranges. The domain must bound ``H/r_b`` and
    ``t/r_b`` (directly, or through ``H``, ``t`` and ``r_b``): :meth:`ConstantsSet.check`
    proves the forms physical there (:mod:`dpfexplore.model.set_checks`).

Files
    :func:`load_constants_set` reads at most
    :data:`~dpfexplore.model.set_checks.fields.MAX_SET_BYTES` of a regular file as strict JSON
    and checks every field's type and magnitude before it uses any
    (:mod:`~dpfexplore.model.set_checks.fields`); every refusal is one line naming the file.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .closed_form import N_FORMS, ClosedForm, ConstantsSetError, float_powers
from .constants import _ALPHA_TERMS, _KB_TERMS, TIP_PER_HEIGHT, TIP_PER_THICKNESS
from .domain import FITTED_RANGES
from .quantities import SET_FORMS, scaled
from .set_checks.claims import claims_problem, data_hull
from .set_checks.fields import fields_problem, read_set_json

__all__ = [
    "CONSTANTS_FORMAT",
    "DEFAULT",
    "ClosedForm",
    "ConstantsSet",
    "ConstantsSetError",
    "data_hull",
    "find_constants_set",
    "load_constants_set",
    "locate_constants_set",
    "packaged_sets",
]

#: Identifies the file layout; bump when it changes incompatibly.
CONSTANTS_FORMAT = "dpfexplore-constants/1"
#: Ranges a domain may state: name -> (unit, per unit of the finger (True) or shared).
DOMAIN_KEYS: dict[str, tuple[str, bool]] = {
    "H": ("mm", True),
    "t": ("mm", False),
    "r_b": ("mm", False),
    "E": ("MPa", False),
    "nu": ("", False),
    "H_over_rb": ("", True),
    "t_over_rb": ("", False),
}


@dataclass(frozen=True, eq=False)
class ConstantsSet:
    """The closed forms for ``k_b``, ``alpha`` and the reach, their domain and provenance.

    One :class:`ClosedForm` field per row of :data:`~dpfexplore.model.quantities.SET_FORMS`, in
    its order (checked when this module is imported).

    Two sets are equal when their fingerprints are (the same forms, domain and provenance), so
    designs and batches that carry a set compare and hash by it.

    Attributes
    ----------
    name : str
    k_hat, alpha, tip_ratio : ClosedForm
        ``k_b R / (E t²)``, ``alpha`` and ``tip_dis / H`` in ``π1 = t/H``, ``π3 = H/R``.
    domain : dict of str to (float, float)
        Where the forms were fitted: ranges among :data:`DOMAIN_KEYS` (module docstring).
    provenance : dict
        How the set was made (method, settings, data checksum, package versions).
    hull : tuple of (float, float), optional
        Vertices of the convex hull of the data's ``(H/r_b, t/r_b)`` (counter-clockwise); when
        given, a dome is in the domain only inside it too (the ranges alone would also admit
        the corners of the box the data never reached).
    validation : dict, optional
        A verdict against printed fingers (:mod:`dpfexplore.measurements.verdict`); unfingerprinted.
    """

    name: str
    k_hat: ClosedForm
    alpha: ClosedForm
    tip_ratio: ClosedForm
    domain: dict[str, tuple[float, float]]
    provenance: dict[str, Any] = field(default_factory=dict)
    hull: tuple[tuple[float, float], ...] | None = None
    validation: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        for key in self.domain:
            if key not in DOMAIN_KEYS:
                raise ConstantsSetError(
                    f"constants set {self.name!r}: unknown domain range {key!r}; "
                    f"known: {', '.join(DOMAIN_KEYS)}"
                )
        self.ratio_ranges()  # the domain must bound H/r_b and t/r_b
        if self.hull is not None:
            vertices = np.asarray(self.hull, dtype=float)
            if vertices.ndim != 2 or vertices.shape[0] < 3 or vertices.shape[1] != 2:
                raise ConstantsSetError(
                    f"constants set {self.name!r}: hull needs at least 3 (H/r_b, t/r_b) vertices"
                )
            if not np.all(np.isfinite(vertices)):
                raise ConstantsSetError(f"constants set {self.name!r}: hull has non-finite values")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ConstantsSet):
            return NotImplemented
        return self is other or self.fingerprint == other.fingerprint

    def __hash__(self) -> int:
        return hash(self.fingerprint)

    def __repr__(self) -> str:
        return f"ConstantsSet({self.name!r}, fingerprint={self.fingerprint[:12]}...)"

    @property
    def label(self) -> str:
        """``name (fingerprint prefix)``: how messages and reports name the set."""
        return f"{self.name!r} ({self.fingerprint[:12]})"

    # ------------------------------------------------------------------ evaluation

    def evaluate(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, E: ArrayLike
    ) -> dict[str, NDArray]:
        """``k_b`` (N/mm), ``alpha`` and ``tip_dis`` (mm) of domes ``H, t, r_b`` (mm), ``E``.

        One entry per row of :data:`~dpfexplore.model.quantities.SET_FORMS` (its quantity).
        ``E`` in MPa; all arguments broadcast. The arithmetic of the kernels
        (:func:`dpfexplore._kernels.tables.set_forms.set_constants_block`).
        """
        H, t, r_b, E = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (H, t, r_b, E)))
        R = (H * H + r_b * r_b) / (2.0 * H)
        pi1, pi3 = t / H, H / R
        return {
            form.quantity: scaled(form.scale, getattr(self, form.name)(pi1, pi3), H, t, R, E)
            for form in SET_FORMS
        }

    def dome(self, E: float, H: float, t: float, r_b: float) -> tuple[float, float]:
        """``(k_b, alpha)`` of one dome in plain Python floats (N/mm, --).

        The arithmetic of the kernels
        (:func:`dpfexplore._kernels.tables.set_forms.set_constants_block`) term by term, so the
        numbers are theirs bit for bit; for checking one design without NumPy's per-call cost.
        """
        R = (H * H + r_b * r_b) / (2.0 * H)
        powers1, powers3 = float_powers(t / H), float_powers(H / R)
        k_hat, alpha = self.k_hat.at(powers1, powers3), self.alpha.at(powers1, powers3)
        return E * (t * t) / R * k_hat, alpha

    def reach(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, U_sep: ArrayLike, t_ch: ArrayLike
    ) -> NDArray:
        """The unclamped reach ``d = tip_dis − H − U_sep − t_ch/2 − t/2`` (mm, MODEL.md §3)."""
        tip = self.evaluate(H, t, r_b, 1.0)["tip_dis"]
        return (
            tip - np.asarray(H) - np.asarray(U_sep) - np.asarray(t_ch) / 2.0 - np.asarray(t) / 2.0
        )

    def springs(
        self,
        H: ArrayLike,
        t: ArrayLike,
        r_b: ArrayLike,
        E: ArrayLike,
        U_sep: ArrayLike,
        t_ch: ArrayLike,
    ) -> dict[str, NDArray]:
        """The dome springs of MODEL.md §3 under this set (broadcasting).

        Returns ``k_b`` (N/mm), ``alpha``, ``d`` (mm; the implementation's
        :data:`~dpfexplore.model.constants.NO_CONTACT_REACH` where the reach is not positive)
        and ``no_contact`` (bool: where it was clamped), as the kernel tables hold them.
        """
        from .constants import NO_CONTACT_REACH

        values = self.evaluate(H, t, r_b, E)
        H, t, U_sep, t_ch = (np.asarray(a, dtype=float) for a in (H, t, U_sep, t_ch))
        raw = values["tip_dis"] - H - U_sep - t_ch / 2.0 - t / 2.0
        no_contact = raw <= 0.0
        return {
            "k_b": values["k_b"],
            "alpha": values["alpha"],
            "d": np.where(no_contact, NO_CONTACT_REACH, raw),
            "no_contact": no_contact,
        }

    def kernel_forms(self) -> tuple[NDArray, NDArray]:
        """The closed forms as the record the kernels read.

        Returns
        -------
        powers : ndarray of int64, shape (N_FORMS, n_terms, 2)
            ``(p, q)`` of each term; rows ``FORM_*`` of :mod:`.closed_form` (the order of
            :data:`~dpfexplore.model.quantities.SET_FORMS`).
        coefficients : ndarray of shape (N_FORMS, n_terms)
            ``c`` of each term. Shorter forms are padded with terms ``0 · π1⁰ · π3⁰``, which
            add nothing. Both arrays cached and read-only.
        """
        cached = self.__dict__.get("_kernel_forms")
        if cached is None:
            forms = [getattr(self, form.name) for form in SET_FORMS]
            width = max(1, *(len(f.coefficients) for f in forms))
            powers = np.zeros((N_FORMS, width, 2), dtype=np.int64)
            coefficients = np.zeros((N_FORMS, width))
            for i, form in enumerate(forms):
                terms = zip(form.exponents, form.coefficients, strict=True)
                for j, ((p, q), c) in enumerate(terms):
                    powers[i, j] = (p, q)
                    coefficients[i, j] = c
            powers.flags.writeable = False
            coefficients.flags.writeable = False
            cached = (powers, coefficients)
            object.__setattr__(self, "_kernel_forms", cached)
        return cached

    def ratio_ranges(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The ``(H/r_b, t/r_b)`` ranges the domain bounds (stated, or from ``H``, ``t``, ``r_b``).

        Raises
        ------
        ConstantsSetError
            When the domain bounds neither.
        """
        d = self.domain
        out = []
        for ratio, length in (("H_over_rb", "H"), ("t_over_rb", "t")):
            if ratio in d:
                out.append(tuple(d[ratio]))
            elif length in d and "r_b" in d and d["r_b"][0] > 0:
                out.append((d[length][0] / d["r_b"][1], d[length][1] / d["r_b"][0]))
            else:
                raise ConstantsSetError(
                    f"constants set {self.name!r}: its domain must bound {ratio} "
                    f"(give {ratio}, or {length} and r_b)"
                )
        return out[0], out[1]

    def domain_values(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, E: ArrayLike, nu: ArrayLike
    ) -> dict[str, NDArray]:
        """The quantities a domain may bound, for domes ``H, t, r_b, E, nu`` (broadcasting)."""
        H, t, r_b, E, nu = (np.asarray(a, dtype=float) for a in (H, t, r_b, E, nu))
        with np.errstate(all="ignore"):
            return {
                "H": H,
                "t": t,
                "r_b": r_b,
                "E": E,
                "nu": nu,
                "H_over_rb": H / r_b,
                "t_over_rb": t / r_b,
            }

    def in_domain(
        self, H: ArrayLike, t: ArrayLike, r_b: ArrayLike, E: ArrayLike, nu: ArrayLike = 0.35
    ) -> NDArray:
        """Whether each dome lies in the set's fitted domain (NaN counts as outside)."""
        values = self.domain_values(H, t, r_b, E, nu)
        inside = np.ones(np.broadcast(*values.values()).shape, dtype=bool)
        with np.errstate(invalid="ignore"):
            for key, (lo, hi) in self.domain.items():
                value = values[key]
                inside &= (value >= lo - 1e-12 * abs(lo)) & (value <= hi + 1e-12 * abs(hi))
        return inside & self.inside_hull(values["H_over_rb"], values["t_over_rb"])

    def inside_hull(self, h: ArrayLike, s: ArrayLike) -> NDArray:
        """Whether each ``(H/r_b, t/r_b)`` lies in the data's hull (all True without a hull).

        A point on the boundary counts as inside (to 1e-12 of the hull's size); NaN as outside.
        """
        h, s = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(s, dtype=float))
        if self.hull is None:
            return np.ones(h.shape, dtype=bool)
        vertices = np.asarray(self.hull, dtype=float)
        edges = np.roll(vertices, -1, axis=0) - vertices
        scale = float(np.abs(vertices).max())
        inside = np.isfinite(h) & np.isfinite(s)
        with np.errstate(invalid="ignore"):
            for (x0, y0), (dx, dy) in zip(vertices, edges, strict=True):
                # counter-clockwise: the inside is on the left of every edge
                cross = dx * (s - y0) - dy * (h - x0)
                inside &= cross >= -1e-12 * scale * np.hypot(dx, dy)
        return inside

    def check(self) -> None:
        """Refuse a set whose claims do not hold over its own domain.

        Proven, not sampled (:mod:`dpfexplore.model.set_checks.claims`): every coefficient and
        range within the limits of a physical set; the hull, if any, a convex polygon inside
        the ranges that reaches the ranges it states; and over the whole domain (the box of
        :meth:`ratio_ranges`, within the hull) ``k_b > 0``, ``0 < alpha < 1``,
        ``H < tip_dis``, with ``k_hat`` and ``tip_ratio`` bounded (``k_b`` scales with ``E``,
        so one ``E`` suffices).

        Raises
        ------
        ConstantsSetError
            ``constants set NAME: ...``, naming what is wrong and, for a form, the dome where
            its quantity is not physical (or, within rounding of its bound, near which).
        """
        hull = None if self.hull is None else np.asarray(self.hull, dtype=float)
        forms = {form.name: getattr(self, form.name) for form in SET_FORMS}
        problem = claims_problem(forms, self.domain, self.ratio_ranges(), hull)
        if problem:
            raise ConstantsSetError(f"constants set {self.name!r}: {problem}")

    # ------------------------------------------------------------------ files

    def to_dict(self) -> dict[str, Any]:
        """The set as JSON-ready data, with its fingerprint."""
        body, extra = self._body(), {"validation": self.validation} if self.validation else {}
        return {**body, "fingerprint": _fingerprint(body), **extra}

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the set's canonical JSON (without the fingerprint itself)."""
        cached = self.__dict__.get("_fingerprint")
        if cached is None:
            cached = _fingerprint(self._body())
            object.__setattr__(self, "_fingerprint", cached)
        return cached

    def _body(self) -> dict[str, Any]:
        return {
            "format": CONSTANTS_FORMAT,
            "name": self.name,
            **{form.name: getattr(self, form.name).to_dict() for form in SET_FORMS},
            "domain": {k: list(v) for k, v in self.domain.items()},
            "provenance": self.provenance,
            # only when present, so that sets without a hull keep their fingerprints
            **({"hull": [list(v) for v in self.hull]} if self.hull is not None else {}),
        }

    def save(self, path: str | Path) -> Path:
        """Write the set as JSON (atomically; folders created) and return the path."""
        from ..io.files import atomic_write

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")
        return path

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "constants set") -> ConstantsSet:
        """Read :meth:`to_dict`'s data; the fingerprint must match and the set be physical."""
        if not isinstance(data, Mapping):
            raise ConstantsSetError(f"{source}: not a constants set (a JSON object)")
        written = data.get("format")
        if written != CONSTANTS_FORMAT:
            shown = (
                repr(written[:80])
                if isinstance(written, str)
                else "None"
                if written is None
                else f"of type {type(written).__name__}"
            )
            raise ConstantsSetError(f"{source}: format {shown}, expected {CONSTANTS_FORMAT!r}")
        for key in ("name", *(form.name for form in SET_FORMS), "domain", "fingerprint"):
            if key not in data:
                raise ConstantsSetError(f"{source}: missing {key!r}")
        body = {k: v for k, v in data.items() if k not in ("fingerprint", "validation")}
        try:
            fingerprint = _fingerprint(body)
        except (TypeError, ValueError, RecursionError) as exc:  # NaN, a non-JSON value
            raise ConstantsSetError(f"{source}: not a constants set ({exc})") from None
        if fingerprint != data["fingerprint"]:
            raise ConstantsSetError(
                f"{source}: its contents do not match its fingerprint (edited or damaged)"
            )
        # Same fingerprint, same contents: a set read and checked before is not checked again
        # (the check proves its forms over its domain, ~0.2-1.5 ms; estimators read their set
        # on every prediction).
        verdict = _verdict(data.get("validation"), data["fingerprint"], source)
        known = _READ_SETS.get(data["fingerprint"])
        if known is not None and known.validation == verdict:
            return known
        problem = fields_problem(data)
        if problem:
            raise ConstantsSetError(f"{source}: {problem}")
        domain = {str(k): (float(v[0]), float(v[1])) for k, v in data["domain"].items()}
        try:
            result = cls(
                name=data["name"],
                **{
                    form.name: ClosedForm.from_dict(data[form.name], f"{source}: {form.name}")
                    for form in SET_FORMS
                },
                domain=domain,
                provenance=dict(data.get("provenance") or {}),
                hull=_hull(data.get("hull")),
                validation=verdict,
            )
            result.check()
        except ConstantsSetError as exc:
            message = str(exc)
            raise ConstantsSetError(
                message if message.startswith(source) else f"{source}: {message}"
            ) from None
        if len(_READ_SETS) >= 64:
            _READ_SETS.clear()
        _READ_SETS[data["fingerprint"]] = result
        return result


def _check_form_fields() -> None:
    """Fail at import when :data:`SET_FORMS` and :class:`ConstantsSet`'s forms disagree.

    :class:`ConstantsSet` spells its closed forms out as typed, documented fields (its callers
    construct it by keyword); they must be the table's forms, in its order.
    """
    fields = [f.name for f in dataclasses.fields(ConstantsSet) if f.type == "ClosedForm"]
    names = [form.name for form in SET_FORMS]
    if fields != names:
        raise ImportError(
            "dpfexplore.model.quantities.SET_FORMS and ConstantsSet disagree: the table's forms "
            f"are {names}, the set's ClosedForm fields {fields}"
        )


_check_form_fields()

#: Sets :meth:`ConstantsSet.from_dict` has read and checked, by fingerprint (a few at most).
_READ_SETS: dict[str, ConstantsSet] = {}


def _verdict(value: Any, fingerprint: str, source: str) -> dict[str, Any] | None:
    """A file's ``validation``: a verdict (``passes``, ``summary``) on this very set, or None."""
    if value is not None and not (
        isinstance(value, dict)
        and isinstance(value.get("passes"), bool)
        and isinstance(value.get("summary"), str)
        and value.get("set_fingerprint") == fingerprint
    ):
        raise ConstantsSetError(f"{source}: validation is not a verdict on this set (re-record it)")
    return value


def _hull(value: Any) -> tuple[tuple[float, float], ...] | None:
    """A file's ``hull`` (its fields checked) as vertices, or None."""
    return None if value is None else tuple((float(a), float(b)) for a, b in value)


def _fingerprint(body: Mapping[str, Any]) -> str:
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(canonical.encode()).hexdigest()


#: Folder of the constants sets that ship with the package (``NAME.json``).
PACKAGED_DIR = Path(__file__).resolve().parent.parent / "data" / "constants"


def packaged_sets() -> list[str]:
    """Names of the packaged constants sets (besides ``paper``, the built-in default)."""
    return sorted(
        p.stem for p in PACKAGED_DIR.glob("*.json") if not p.name.endswith(".report.json")
    )


#: ``results/constants/NAME/constants.json`` (``identify fit``'s default) is the set ``NAME``.
SAVED_DIR, SAVED_FILE = Path("results") / "constants", "constants.json"


def locate_constants_set(text: str | Path, base: str | Path | None = None) -> Path | None:
    """The file of the set a user names (None for ``paper``): the one resolution of set names.

    In order: an existing file (relative to ``base``, the folder of a TOML file naming it); a
    folder holding ``constants.json`` (a saved identification); a saved identification's name
    (:data:`SAVED_DIR`); any other path (``.json``, or with a folder); ``paper``; a packaged
    set. Local names win, as a design file in the working directory wins over an example.
    Raises :class:`ConstantsSetError` (one line, listing the packaged sets) for no such set.
    """
    given = Path(text).expanduser()
    path = Path(base) / given if base is not None and not given.is_absolute() else given
    with contextlib.suppress(OSError):  # a name too long for a path: the reader says so
        if path.is_dir() and not (path / SAVED_FILE).is_file():
            raise ConstantsSetError(
                f"{text}: a folder without {SAVED_FILE} (a saved identification)"
            )
        if path.exists():
            return path / SAVED_FILE if path.is_dir() else path
        if (
            len(given.parts) == 1
            and not given.suffix
            and (SAVED_DIR / given / SAVED_FILE).is_file()
        ):
            return SAVED_DIR / given / SAVED_FILE
    if path.suffix == ".json" or len(given.parts) > 1 or len(str(text)) > 255:
        return path  # the reader names the file and its problem
    if str(text) in (DEFAULT.name, *packaged_sets()):
        return None if str(text) == DEFAULT.name else PACKAGED_DIR / f"{text}.json"
    known = ", ".join([DEFAULT.name, *packaged_sets()])
    raise ConstantsSetError(
        f"{text}: no such constants set file, saved identification ({SAVED_DIR}/{text}/) "
        f"or packaged set (packaged sets: {known})"
    )


def find_constants_set(text: str | Path, base: str | Path | None = None) -> ConstantsSet:
    """The set a user names, for every command and file (:func:`locate_constants_set`)."""
    path = locate_constants_set(text, base)
    return DEFAULT if path is None else load_constants_set(path)


def load_constants_set(path: str | Path) -> ConstantsSet:
    """Read a constants set file (a JSON file written by :meth:`ConstantsSet.save`).

    Raises
    ------
    ConstantsSetError
        One line naming the file: unreadable, not a regular file or too large
        (:func:`~dpfexplore.model.set_checks.fields.read_set_json`), not strict JSON, another
        format, a field of the wrong type or magnitude, a fingerprint that does not match, or
        claims that do not hold (:meth:`ConstantsSet.check`).
    """
    path = Path(path)
    result = ConstantsSet.from_dict(read_set_json(path), source=str(path))
    if result.validation is not None and not result.validation["passes"]:
        logging.getLogger("dpfexplore.validation").warning(result.validation["summary"])
    return result


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
#: the fitted ranges H 3-5 mm, t 0.5-1 mm at r_b = 5 mm, E 5-40 MPa (no ``nu`` range: the
#: module docstring says why).
DEFAULT = ConstantsSet(
    name="paper",
    k_hat=_paper_form(_KB_TERMS, kb=True),
    alpha=_paper_form(_ALPHA_TERMS, kb=False),
    tip_ratio=ClosedForm(((0, 0), (1, 0)), (TIP_PER_HEIGHT, TIP_PER_THICKNESS)),
    domain={name: (low, high) for name, (low, high, _) in FITTED_RANGES.items()},
    provenance={
        "method": "the paper's regressions (eq. kb_model, alpha_model, d_model) with the "
        "coefficients of the authors' implementation",
        "source": "Osorio et al., SI 'Parameter Tuning'; MODEL.md §3",
    },
)
