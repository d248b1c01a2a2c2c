"""Designs, materials and their validation: the one place where inputs are checked.

A :class:`Design` is one finger (MODEL.md §2); a :class:`DesignBatch` is many fingers as a
struct of arrays, padded to ``MAX_UNITS`` units, for the batch kernels. A single bad design raises
``ValueError`` naming the field and the value; a batch never raises for a bad row, it gives the
row a status code (:func:`DesignBatch.status`) so that one bad design never stops a sweep.

Lengths in mm, ``E`` in MPa.

Every design and batch carries the constants set its domes' closed forms come from
(:mod:`dpfexplore.model.constants_set`; the paper's, :data:`DEFAULT`, unless given): the
validation, the kernel tables and the fitted-range flag all read it. A batch holds one set.
The rules of the validation and their messages live in :mod:`dpfexplore.model.validation`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..io.toml_fields import read_toml
from . import status as st
from .constants_set import (
    DEFAULT,
    DOMAIN_KEYS,
    ConstantsSet,
    find_constants_set,
)
from .domain import MAX_UNITS, active_units, fitted_range
from .formatting import nums as _nums
from .materials import MATERIALS, Material, material
from .validation import PER_UNIT_FIELDS, SHARED_FIELDS, problems, status_code

__all__ = [
    "MATERIALS",
    "MAX_UNITS",
    "Design",
    "DesignBatch",
    "Material",
    "load_design",
    "material",
]


DEFAULTS = {"E": 26.0, "nu": 0.35, "r_b": 5.0, "t_ch": 1.0}


def _per_unit(name: str, value: Any, n_units: int) -> tuple[float, ...]:
    if isinstance(value, (str, bytes, Mapping)):
        raise ValueError(f"{name} = {value!r}: must be a number or a list of numbers")
    if not _is_list(value):
        return (_number(name, value),) * n_units
    values = tuple(_number(f"{name}[unit {k + 1}]", v) for k, v in enumerate(value))
    if len(values) != n_units:
        raise ValueError(
            f"{name} = {_nums(value)}: has {len(values)} values but the design has "
            f"{n_units} units (len(H)); give one value or one per unit"
        )
    return values


def _is_list(value: Any) -> bool:
    """Whether ``value`` is a list, tuple or array of per-unit values.

    Its elements are then checked one by one, so a ragged nesting is named by unit instead of
    failing inside NumPy.
    """
    if isinstance(value, np.ndarray):
        return value.ndim >= 1
    return isinstance(value, (list, tuple))


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} = {value!r}: must be a number")
    try:
        return float(value)
    except OverflowError:  # an integer beyond the largest float
        raise ValueError(
            f"{name} = an integer of {int(value).bit_length()} bits: too large"
        ) from None


def _constants_set(value: Any) -> ConstantsSet:
    if isinstance(value, ConstantsSet):
        return value
    if isinstance(value, (str, Path)):
        return find_constants_set(value)
    raise ValueError(
        f"constants = {value!r}: must be a ConstantsSet or the path of a constants set file"
    )


def resolve_constants(value: str | Path, base: str | Path | None = None) -> ConstantsSet:
    """The constants set a TOML file's ``constants`` key names, a path relative to ``base``.

    A path, a saved identification's name, ``paper`` or a packaged set's name, resolved as
    every ``--constants`` option is (:func:`~dpfexplore.model.constants_set.find_constants_set`).

    Raises
    ------
    ValueError
        One line naming the file or name
        (:class:`~dpfexplore.model.constants_set.ConstantsSetError`).
    """
    return find_constants_set(value, base)


@dataclass(frozen=True)
class Design:
    """One Dome Phalanx Finger (MODEL.md §2).

    Per-unit parameters accept a scalar (same for every unit) or one value per unit, unit 1
    (the base) first; the number of units ``N`` is ``len(H)``.

    Parameters
    ----------
    H : sequence of float, mm
        Dome height per unit.
    U_L : float or sequence of float, mm
        Unit length per unit (the implementation's "channel length").
    U_sep : float or sequence of float, mm
        Unit separation per unit.
    t : float, mm
        Dome thickness.
    t_lim : float, mm
        Limiting-layer thickness.
    E : float, MPa
        Young's modulus (26 MPa: Cheetah 95A).
    nu : float
        Poisson ratio.
    r_b : float, mm
        Dome base radius.
    t_ch : float, mm
        Chamber wall thickness.
    name : str
        Free-form label (not part of the physics).
    constants : ConstantsSet or path, optional
        The closed forms of ``k_b``, ``alpha`` and the reach (MODEL.md §3): a
        :class:`~dpfexplore.model.constants_set.ConstantsSet` or the path of a constants set
        file; the paper's (:data:`~dpfexplore.model.constants_set.DEFAULT`) by default.

    Raises
    ------
    ValueError
        Naming the field and its value, for non-finite or non-positive lengths, ``N`` outside
        1-12, per-unit lists of the wrong length, a geometry outside the model's physical
        domain (:mod:`dpfexplore.model.domain`: a dome taller than ``r_b`` or than its unit
        length), or constants the closed forms make nonsense (``k_b <= 0``, ``alpha`` outside
        (0, 1)). A design inside the domain but outside the ranges the constants set was
        fitted on is accepted and flagged (:attr:`in_fitted_range`).
    """

    H: tuple[float, ...]
    U_L: tuple[float, ...]
    U_sep: tuple[float, ...]
    t: float
    t_lim: float
    E: float = DEFAULTS["E"]
    nu: float = DEFAULTS["nu"]
    r_b: float = DEFAULTS["r_b"]
    t_ch: float = DEFAULTS["t_ch"]
    name: str = field(default="", compare=False)
    constants: ConstantsSet = field(default=DEFAULT, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "constants", _constants_set(self.constants))
        H = self.H
        if not _is_list(H) or (isinstance(H, np.ndarray) and H.ndim != 1):
            raise ValueError(f"H = {H!r}: must be a list with one dome height per unit")
        n_units = len(H)
        if not 1 <= n_units <= MAX_UNITS:
            raise ValueError(f"N = {n_units} (len(H)): must be between 1 and {MAX_UNITS}")
        object.__setattr__(self, "H", _per_unit("H", H, n_units))
        for name in ("U_L", "U_sep"):
            object.__setattr__(self, name, _per_unit(name, getattr(self, name), n_units))
        for name in SHARED_FIELDS:
            object.__setattr__(self, name, _number(name, getattr(self, name)))
        shared = tuple(getattr(self, name) for name in SHARED_FIELDS)
        if status_code(n_units, self.H, self.U_L, self.U_sep, shared, self.constants) != st.OK:
            _, message = DesignBatch.from_designs([self]).problems()
            raise ValueError(message[0])

    @property
    def n_units(self) -> int:
        """Number of units ``N``."""
        return len(self.H)

    @property
    def in_fitted_range(self) -> bool:
        """Whether the design lies in the domain its constants set was fitted on.

        The set's :attr:`~dpfexplore.model.constants_set.ConstantsSet.domain` (for the paper's,
        :data:`dpfexplore.model.domain.FITTED_RANGES`); outside, every result of this design is
        an extrapolation of the closed forms (MODEL.md §3) and is flagged as such.
        """
        return self.fitted_range_note is None

    @property
    def fitted_range_note(self) -> str | None:
        """One line naming what lies outside the fitted ranges, or None when inside.

        E.g. ``"H[unit 1] = 1.1 mm below the fitted 3-5 mm"``.
        """
        return DesignBatch.from_designs([self]).fitted_range_notes()[0]

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, base: str | Path | None = None) -> Design:
        """Build a design from a mapping such as a TOML ``[design]`` table.

        ``material = "cheetah-95a"`` sets ``E`` and ``nu`` from :data:`MATERIALS`; giving both
        ``material`` and ``E`` is an error (which one would win is a guess). ``constants =
        "FILE"`` names a constants set file, relative to ``base`` (the folder of the file the
        table came from) unless absolute.
        """
        known = {"H", "U_L", "U_sep", *SHARED_FIELDS, "material", "name", "constants"}
        for key in data:
            if key not in known:
                raise ValueError(
                    f"{key} = {data[key]!r}: unknown design key; known: {', '.join(sorted(known))}"
                )
        for key in ("H", "U_L", "U_sep", "t", "t_lim"):
            if key not in data:
                raise ValueError(f"{key}: missing design key")
        values = dict(data)
        if "material" in values:
            if "E" in values:
                raise ValueError(
                    f"material = {values['material']!r}: give either material or E, not both"
                )
            preset = material(str(values.pop("material")))
            values["E"] = preset.E
            values.setdefault("nu", preset.nu)
        if isinstance(values.get("constants"), str):
            values["constants"] = resolve_constants(values["constants"], base)
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """Plain mapping (lists for per-unit fields) that :meth:`from_dict` reads back.

        The geometry and material only: the constants set is not a design parameter, and
        whoever writes a design down records the set beside it (by fingerprint).
        """
        out: dict[str, Any] = {"H": list(self.H), "U_L": list(self.U_L), "U_sep": list(self.U_sep)}
        out.update({name: getattr(self, name) for name in SHARED_FIELDS})
        if self.name:
            out["name"] = self.name
        return out

    def replace(self, **changes: Any) -> Design:
        """Copy with some fields changed (validated again)."""
        values = {**self.to_dict(), "constants": self.constants}
        values.update(changes)
        return Design(**values)


def load_design(path: str | Path) -> Design:
    """Read a design from the ``[design]`` table of a TOML file.

    Raises
    ------
    ValueError
        If the file cannot be read (missing, a directory, not TOML), has no ``[design]`` table,
        or the design is invalid (naming the key).
    """
    path = Path(path)
    try:
        document = read_toml(path, "design")  # "PATH: not valid TOML (...)", a ValueError
    except FileNotFoundError:
        raise ValueError(f"{path}: no such design file") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a directory, not a design file (TOML)") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (a design is TOML)") from None
    if "design" not in document:
        raise ValueError(f"{path}: missing [design] table")
    table = document["design"]
    if not isinstance(table, Mapping):
        raise ValueError(
            f"{path}: [design] must be a table of design keys (H = [...], t = ...), "
            f"not a {type(table).__name__}"
        )
    data = dict(table)
    data.setdefault("name", path.stem)
    try:
        return Design.from_dict(data, base=path.parent)
    except ValueError as exc:
        raise ValueError(f"{path}: [design] {exc}") from None


@dataclass(frozen=True)
class DesignBatch:
    """Many designs as a struct of arrays (per-unit arrays NaN-padded to ``MAX_UNITS``).

    Attributes
    ----------
    n_units : ndarray of int64, shape (n,)
    H, U_L, U_sep : ndarray of shape (n, MAX_UNITS), mm
    t, t_lim, E, nu, r_b, t_ch : ndarray of shape (n,)
        As in :class:`Design` (mm, MPa).
    constants : ConstantsSet
        The constants set of every design of the batch (keyword only; the paper's by default).
    """

    #: The array attributes, in order (everything but :attr:`constants`).
    ARRAY_FIELDS = ("n_units", *PER_UNIT_FIELDS, *SHARED_FIELDS)

    n_units: NDArray[np.int64]
    H: NDArray[np.float64]
    U_L: NDArray[np.float64]
    U_sep: NDArray[np.float64]
    t: NDArray[np.float64]
    t_lim: NDArray[np.float64]
    E: NDArray[np.float64]
    nu: NDArray[np.float64]
    r_b: NDArray[np.float64]
    t_ch: NDArray[np.float64]
    constants: ConstantsSet = field(default=DEFAULT, kw_only=True, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "constants", _constants_set(self.constants))
        # Writable arrays (copied only when not): Numba types a read-only array (one read back
        # from Parquet, say) as another type and would compile every kernel again for it.
        n = np.asarray(self.n_units).shape[0]
        counts = np.asarray(self.n_units, dtype=np.int64).reshape(n)
        object.__setattr__(self, "n_units", np.require(counts, requirements="W"))
        for name in PER_UNIT_FIELDS:
            arr = np.require(np.asarray(getattr(self, name), dtype=np.float64), requirements="W")
            if arr.shape != (n, MAX_UNITS):
                raise ValueError(
                    f"{name}: batch array has shape {arr.shape}, need {(n, MAX_UNITS)}"
                )
            object.__setattr__(self, name, arr)
        for name in SHARED_FIELDS:
            arr = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,)).copy()
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return self.n_units.shape[0]

    @classmethod
    def from_designs(
        cls, designs: Sequence[Design], *, constants: ConstantsSet | None = None
    ) -> DesignBatch:
        """Stack designs into a batch.

        The batch takes the designs' constants set (they must share one), or ``constants`` for
        an empty list.

        Raises
        ------
        ValueError
            When the designs carry different constants sets.
        """
        sets = {d.constants for d in designs}
        if len(sets) > 1:
            names = ", ".join(sorted(c.label for c in sets))
            raise ValueError(f"one batch takes one constants set; these designs carry {names}")
        if sets:
            constants = sets.pop()
        n = len(designs)
        per_unit = {name: np.full((n, MAX_UNITS), np.nan) for name in PER_UNIT_FIELDS}
        for i, design in enumerate(designs):
            for name in PER_UNIT_FIELDS:
                values = getattr(design, name)
                per_unit[name][i, : len(values)] = values
        return cls(
            n_units=np.array([d.n_units for d in designs], dtype=np.int64),
            **per_unit,
            **{
                name: np.array([getattr(d, name) for d in designs], float) for name in SHARED_FIELDS
            },
            constants=DEFAULT if constants is None else constants,
        )

    @classmethod
    def concatenate(cls, batches: Sequence[DesignBatch]) -> DesignBatch:
        """The designs of several batches, in order, as one (they must share a constants set).

        Raises
        ------
        ValueError
            For no batches, or batches under different constants sets.
        """
        if not batches:
            raise ValueError("concatenate needs at least one batch")
        sets = {b.constants for b in batches}
        if len(sets) > 1:
            names = ", ".join(sorted(c.label for c in sets))
            raise ValueError(f"one batch takes one constants set; these batches carry {names}")
        return cls(
            **{
                name: np.concatenate([getattr(b, name) for b in batches])
                for name in cls.ARRAY_FIELDS
            },
            constants=batches[0].constants,
        )

    def problems(self) -> tuple[NDArray[np.int8], list[str | None]]:
        """Status code per design and a description of its first problem (None if valid)."""
        per_unit = {name: getattr(self, name) for name in PER_UNIT_FIELDS}
        shared = {name: getattr(self, name) for name in SHARED_FIELDS}
        return problems(self.n_units, per_unit, shared, self.constants)

    def status(self) -> NDArray[np.int8]:
        """Status code per design (``OK``, ``INVALID_INPUT``, ``OUTSIDE_DOMAIN``, ...)."""
        return self.problems()[0]

    def in_fitted_range(self) -> NDArray[np.bool_]:
        """Per design, :attr:`Design.in_fitted_range`: ndarray of bool, shape ``(n,)``."""
        return self._fitted_range()[0]

    def fitted_range_notes(self) -> list[str | None]:
        """Per design, :attr:`Design.fitted_range_note` (None when inside the fitted ranges)."""
        return self._fitted_range()[1]

    def _fitted_range(self) -> tuple[NDArray[np.bool_], list[str | None]]:
        values = self.constants.domain_values(
            self.H, self.t[:, None], self.r_b[:, None], self.E[:, None], self.nu[:, None]
        )
        # shared quantities as (n,), per-unit ones as (n, MAX_UNITS)
        values = {k: v if DOMAIN_KEYS[k][1] else v[:, 0] for k, v in values.items()}
        inside, notes = fitted_range(self.n_units, values, self.constants.domain)
        if self.constants.hull is None:
            return inside, notes
        h, s = values["H_over_rb"], values["t_over_rb"][:, None]
        outside = active_units(self.n_units) & ~self.constants.inside_hull(h, s)
        for i in np.flatnonzero(outside.any(axis=1)):
            k = int(np.flatnonzero(outside[i])[0])
            text = (
                f"(H/r_b, t/r_b)[unit {k + 1}] = ({h[i, k]:.4g}, {s[i, 0]:.4g}) outside the "
                "hull of the data the constants set was fitted on"
            )
            inside[i] = False
            notes[i] = f"{notes[i]}; {text}" if notes[i] else text
        return inside, notes

    def design(self, i: int) -> Design:
        """Row ``i`` as a :class:`Design` (raises ``ValueError`` if that row is invalid)."""
        n = int(self.n_units[i])
        if not 1 <= n <= MAX_UNITS:
            raise ValueError(f"N = {n}: must be between 1 and {MAX_UNITS}")
        return Design(
            H=tuple(self.H[i, :n]),
            U_L=tuple(self.U_L[i, :n]),
            U_sep=tuple(self.U_sep[i, :n]),
            **{name: float(getattr(self, name)[i]) for name in SHARED_FIELDS},
            constants=self.constants,
        )

    def take(self, index: NDArray) -> DesignBatch:
        """Sub-batch of the given rows."""
        return DesignBatch(
            **{name: getattr(self, name)[index] for name in self.ARRAY_FIELDS},
            constants=self.constants,
        )

    def with_arrays(self, **arrays: NDArray) -> DesignBatch:
        """A batch of other arrays under the same constants set (missing arrays kept)."""
        values = {name: getattr(self, name) for name in self.ARRAY_FIELDS}
        values.update(arrays)
        return DesignBatch(**values, constants=self.constants)
