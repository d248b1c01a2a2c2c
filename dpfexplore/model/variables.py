"""Design variables of an inverse problem: bounds and constraints as an exact reparametrisation.

An inverse problem (lookup refinement, a scene's optimiser) moves in a box ``z ∈ [0, 1]^m`` and
maps every point of that box to a design that satisfies its constraints *exactly*; no penalty
is needed and no infeasible design is ever evaluated. :class:`DesignVariables` says which
parameters are free, within which bounds, and how they are tied; it maps ``z`` to designs
(:meth:`~DesignVariables.designs`), gives the Jacobian of the design parameters with respect to
``z`` (:meth:`~DesignVariables.jacobian`) for the chain rule with the model's sensitivities,
and maps designs back to ``z`` (:meth:`~DesignVariables.encode`) to seed a search with known
designs.

The map
    * A fixed parameter (``low == high``) takes no variable.
    * An unordered free parameter is affine in its variable: ``θ = low + (high - low) z``.
    * Dome heights under an order constraint form a chain over the units it covers (unit order,
      unit 1 at the base). The first height of the chain is affine in its variable; each next
      one is placed in the interval its predecessor leaves it::

          H_k = a_k + (b_k - a_k) w_k,   [a_k, b_k] = [lo_k, min(hi_k, H_prev)]   descending
                                         [a_k, b_k] = [max(lo_k, H_prev), hi_k]   ascending

      so ``w_k = 0`` puts ``H_k`` at its own bound and ``w_k = 1`` makes it equal to its
      predecessor. With a minimum step ``δ`` (``min_step``), ``H_prev`` is replaced by
      ``H_prev ± δ`` (consecutive ordered heights differ by at least ``δ``), and every bound is
      the *effective* bound of its place in the chain (e.g. ascending: the first height at most
      the last one's upper bound less the steps between), so every ``w`` stays feasible.
      Every ``w`` in ``[0, 1]`` gives an ordered design inside the bounds, and every
      such design has such a ``w`` (:meth:`~DesignVariables.encode`). The derivative of
      ``min``/``max`` where the two arguments are equal is taken one-sided (the branch of the
      predecessor), a measure-zero set.
    * Tied heights (e.g. ``H_5 = H_6``) share one variable; the tie group takes the intersection
      of its units' bounds and sits in the chain at the position of its first unit.
    * ``U_L`` and ``U_sep`` are either one shared variable or one per unit.

Parameter order of :meth:`~DesignVariables.jacobian` is that of the model's sensitivities
(:func:`parameter_names`, which :mod:`dpfexplore.solvers.sensitivities` follows): ``H_1..H_N,
U_L_1..U_L_N, U_sep_1..U_sep_N, t, t_lim, E``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .constants_set import DEFAULT, ConstantsSet
from .design import DEFAULTS, Design, DesignBatch
from .domain import MAX_UNITS

__all__ = [
    "HEIGHT_ORDERS",
    "SENSITIVITY_PER_UNIT",
    "SENSITIVITY_SHARED",
    "DesignVariables",
    "parameter_names",
]

#: Per-unit parameter kinds of the model's sensitivities, in column order.
SENSITIVITY_PER_UNIT = ("H", "U_L", "U_sep")
#: Shared parameters of the model's sensitivities, after the per-unit ones.
SENSITIVITY_SHARED = ("t", "t_lim", "E")

#: Order constraints on the dome heights (unit 1 is at the base).
HEIGHT_ORDERS = ("free", "ascending", "descending")
#: Parameters that take one value per unit / one value per design.
_PER_UNIT = ("H", "U_L", "U_sep")
_SHARED = ("t", "t_lim")
#: Parameters given as a number (fixed) or ``[low, high]`` (free) for the whole design.
_RANGED = ("U_L", "U_sep", "t", "t_lim")
_FIXED = ("E", "nu", "r_b", "t_ch")
#: How far outside its bounds a decoded parameter may sit from rounding, mm.
_BOUND_SLACK = 1e-12


def parameter_names(n_units: int) -> tuple[str, ...]:
    """Parameter names in sensitivity order: ``("H_1", ..., "U_sep_N", "t", "t_lim", "E")``."""
    per_unit = tuple(f"{kind}_{k}" for kind in SENSITIVITY_PER_UNIT for k in range(1, n_units + 1))
    return per_unit + SENSITIVITY_SHARED


def _interval(name: str, value: float | Sequence[float]) -> tuple[float, float]:
    if isinstance(value, (str, bytes, bool)):
        raise ValueError(f"{name} = {value!r}: give a number or [low, high]")
    if np.ndim(value) == 0:
        low = high = float(value)  # type: ignore[arg-type]
    else:
        if len(value) != 2:  # type: ignore[arg-type]
            raise ValueError(f"{name} = {value!r}: give a number or [low, high]")
        low, high = (float(v) for v in value)  # type: ignore[union-attr]
    if not (np.isfinite(low) and np.isfinite(high) and 0.0 < low <= high):
        raise ValueError(f"{name} = {value!r}: need finite bounds 0 < low <= high")
    return low, high


@dataclass(frozen=True)
class _Slot:
    """One height variable (or fixed height) and the units that take it."""

    units: tuple[int, ...]  # 0-based
    low: float
    high: float

    @property
    def free(self) -> bool:
        return self.high > self.low


@dataclass(frozen=True)
class DesignVariables:
    """The free parameters, bounds and constraints of designs of ``n_units`` units.

    Parameters
    ----------
    n_units : int
        Number of units ``N``.
    H : [low, high], a number, or a sequence of those, one per unit; mm
        Dome height bounds (a number fixes the height).
    U_L, U_sep : [low, high] or a number; mm
        Unit length and separation bounds.
    t, t_lim : [low, high] or a number; mm
        Dome and limiting-layer thickness bounds.
    heights : {"free", "ascending", "descending"}
        Order of the heights over ``ordered_units`` (``H_{k+1} >= H_k`` is ascending).
    ordered_units : sequence of int, optional
        1-based units the order covers, increasing (default all units). The gripper orders
        units 1-4 and leaves its tip unit free.
    tied : sequence of sequences of int
        Groups of 1-based units whose heights are equal (one variable each).
    shared_U_L, shared_U_sep : bool
        One value for all units (default) or one per unit.
    min_step : float, mm
        Least difference between consecutive ordered heights (default 0: equal allowed).
    E, nu, r_b, t_ch : float
        Fixed material and geometry (MPa, 1, mm, mm).
    constants : ConstantsSet
        The closed forms the designs run on (the paper's by default).

    Raises
    ------
    ValueError
        Naming the field, for bounds that are not finite and positive, a per-unit list of the
        wrong length, an unknown order, tie groups that overlap or leave the units, or bounds
        under which no ordered design exists.
    """

    n_units: int
    H: float | Sequence = (3.0, 5.0)
    U_L: float | Sequence[float] = (5.5, 10.0)
    U_sep: float | Sequence[float] = (1.0, 5.0)
    t: float | Sequence[float] = (0.5, 1.0)
    t_lim: float | Sequence[float] = (1.0, 2.0)
    heights: str = "free"
    ordered_units: Sequence[int] | None = None
    tied: Sequence[Sequence[int]] = ()
    shared_U_L: bool = True
    shared_U_sep: bool = True
    min_step: float = 0.0
    E: float = DEFAULTS["E"]
    nu: float = DEFAULTS["nu"]
    r_b: float = DEFAULTS["r_b"]
    t_ch: float = DEFAULTS["t_ch"]
    constants: ConstantsSet = DEFAULT
    _bounds: dict[str, tuple[float, float]] = field(init=False, repr=False, compare=False)
    _slots: tuple[_Slot, ...] = field(init=False, repr=False, compare=False)
    _chain: tuple[int, ...] = field(init=False, repr=False, compare=False)
    _names: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = self.n_units
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_UNITS:
            raise ValueError(f"n_units = {n!r}: must be an integer between 1 and {MAX_UNITS}")
        if self.heights not in HEIGHT_ORDERS:
            raise ValueError(f"heights = {self.heights!r}: choose one of {HEIGHT_ORDERS}")
        bounds = _height_bounds(self.H, n)
        for name in _FIXED:
            value = getattr(self, name)
            if not np.isfinite(value):
                raise ValueError(f"{name} = {value!r}: must be finite")
        object.__setattr__(
            self, "_bounds", {name: _interval(name, getattr(self, name)) for name in _RANGED}
        )
        slots = self._tie_slots(bounds)
        chain = self._ordered_slots(slots)
        if not (np.isfinite(self.min_step) and self.min_step >= 0):
            raise ValueError(f"min_step = {self.min_step!r}: must be finite and >= 0 mm")
        object.__setattr__(self, "_slots", self._effective_slots(slots, chain))
        object.__setattr__(self, "_chain", chain)
        object.__setattr__(self, "_names", self._variable_names())
        if not self._feasible():
            raise ValueError(
                f"heights = {self.heights!r}: no {self.heights} design fits the height bounds "
                f"{[(s.low, s.high) for s in slots]}"
            )

    # ------------------------------------------------------------------ construction helpers

    def _tie_slots(self, bounds: list[tuple[float, float]]) -> tuple[_Slot, ...]:
        n = self.n_units
        group_of: dict[int, tuple[int, ...]] = {}
        for group in self.tied:
            units = tuple(sorted(int(u) - 1 for u in group))
            if len(units) < 2 or units[0] < 0 or units[-1] >= n:
                raise ValueError(f"tied = {list(self.tied)!r}: groups of >= 2 units in 1..{n}")
            for u in units:
                if u in group_of:
                    raise ValueError(f"tied = {list(self.tied)!r}: unit {u + 1} in two groups")
                group_of[u] = units
        slots, seen = [], set()
        for k in range(n):
            if k in seen:
                continue
            units = group_of.get(k, (k,))
            seen.update(units)
            low = max(bounds[u][0] for u in units)
            high = min(bounds[u][1] for u in units)
            if low > high:
                raise ValueError(f"tied = {list(self.tied)!r}: units {units} share no height")
            slots.append(_Slot(units, low, high))
        return tuple(slots)

    def _ordered_slots(self, slots: tuple[_Slot, ...]) -> tuple[int, ...]:
        if self.heights == "free":
            return ()
        ordered = range(1, self.n_units + 1) if self.ordered_units is None else self.ordered_units
        units = [int(u) - 1 for u in ordered]
        if (
            not units
            or units[0] < 0
            or units[-1] >= self.n_units
            or any(b <= a for a, b in pairwise(units))
        ):
            raise ValueError(
                f"ordered_units = {self.ordered_units!r}: increasing units in 1..{self.n_units}"
            )
        chain: list[int] = []
        for u in units:
            s = next(i for i, slot in enumerate(slots) if u in slot.units)
            if not chain or chain[-1] != s:
                if s in chain:
                    raise ValueError(
                        f"tied = {list(self.tied)!r}: a tie group interrupts the order"
                    )
                chain.append(s)
        return tuple(chain)

    def _variable_names(self) -> tuple[str, ...]:
        names = [
            "H_" + "=".join(str(u + 1) for u in slot.units) for slot in self._slots if slot.free
        ]
        for name, shared in (("U_L", self.shared_U_L), ("U_sep", self.shared_U_sep)):
            low, high = self._bounds[name]
            if high > low:
                names += [name] if shared else [f"{name}_{k}" for k in range(1, self.n_units + 1)]
        names += [name for name in _SHARED if self._bounds[name][1] > self._bounds[name][0]]
        return tuple(names)

    def _effective_slots(
        self, slots: tuple[_Slot, ...], chain: tuple[int, ...]
    ) -> tuple[_Slot, ...]:
        """Bounds of the chained slots narrowed to what the order and the steps leave them."""
        if not chain:
            return slots
        step = float(self.min_step)
        sign = 1.0 if self.heights == "ascending" else -1.0
        low = [slots[s].low for s in chain]
        high = [slots[s].high for s in chain]
        for i in range(1, len(chain)):  # forward: each height beyond its predecessor's bound
            if sign > 0:
                low[i] = max(low[i], low[i - 1] + step)
            else:
                high[i] = min(high[i], high[i - 1] - step)
        for i in range(len(chain) - 2, -1, -1):  # backward: room for the heights after it
            if sign > 0:
                high[i] = min(high[i], high[i + 1] - step)
            else:
                low[i] = max(low[i], low[i + 1] + step)
        out = list(slots)
        for i, s in enumerate(chain):
            out[s] = _Slot(slots[s].units, low[i], high[i])
        return tuple(out)

    def _feasible(self) -> bool:
        """Whether an ordered design exists: every chained slot keeps a non-empty interval."""
        return all(self._slots[s].low <= self._slots[s].high + 1e-12 for s in self._chain)

    # ------------------------------------------------------------------ the map

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the variables ``z`` (``"H_5=6"`` for a tie group)."""
        return self._names

    @property
    def n_variables(self) -> int:
        """Number of variables ``m`` (the box is ``[0, 1]^m``)."""
        return len(self._names)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Model parameters in the order of :meth:`jacobian`'s rows."""
        return parameter_names(self.n_units)

    def _decode(self, z: NDArray) -> tuple[dict[str, NDArray], NDArray]:
        """Parameters of every row of ``z`` and ``dθ/dz`` (rows: :attr:`parameters`)."""
        m, n = z.shape[0], self.n_units
        jac = np.zeros((m, 3 * n + 3, self.n_variables))
        H = np.empty((m, n))
        col = 0
        slot_values = np.empty((m, len(self._slots)))
        slot_grad = np.zeros((m, len(self._slots), self.n_variables))
        in_chain = {s: i for i, s in enumerate(self._chain)}
        for s, slot in enumerate(self._slots):
            if slot.free:
                w = z[:, col]
                i = in_chain.get(s)
                if i is None or i == 0:
                    a = np.full(m, slot.low)
                    b = np.full(m, slot.high)
                    da = db = np.zeros((m, self.n_variables))
                else:
                    prev = self._chain[i - 1]
                    step = self.min_step if self.heights == "ascending" else -self.min_step
                    hp = slot_values[:, prev] + step
                    dhp = slot_grad[:, prev]
                    if self.heights == "descending":
                        a = np.full(m, slot.low)
                        da = np.zeros((m, self.n_variables))
                        takes_prev = hp < slot.high
                        b = np.where(takes_prev, hp, slot.high)
                        db = np.where(takes_prev[:, None], dhp, 0.0)
                    else:
                        takes_prev = hp > slot.low
                        a = np.where(takes_prev, hp, slot.low)
                        da = np.where(takes_prev[:, None], dhp, 0.0)
                        b = np.full(m, slot.high)
                        db = np.zeros((m, self.n_variables))
                slot_values[:, s] = a + (b - a) * w
                grad = da + (db - da) * w[:, None]
                grad[:, col] += b - a
                slot_grad[:, s] = grad
                col += 1
            else:
                slot_values[:, s] = slot.low
            for u in slot.units:
                H[:, u] = slot_values[:, s]
                jac[:, u, :] = slot_grad[:, s]
        params: dict[str, NDArray] = {"H": H}
        for j, (name, shared) in enumerate(
            (("U_L", self.shared_U_L), ("U_sep", self.shared_U_sep))
        ):
            low, high = self._bounds[name]
            rows = slice((j + 1) * n, (j + 2) * n)
            if high > low:
                if shared:
                    params[name] = np.repeat((low + (high - low) * z[:, col])[:, None], n, axis=1)
                    jac[:, rows, col] = high - low
                    col += 1
                else:
                    params[name] = low + (high - low) * z[:, col : col + n]
                    for k in range(n):
                        jac[:, (j + 1) * n + k, col + k] = high - low
                    col += n
            else:
                params[name] = np.full((m, n), low)
        for j, name in enumerate(_SHARED):
            low, high = self._bounds[name]
            if high > low:
                params[name] = low + (high - low) * z[:, col]
                jac[:, 3 * n + j, col] = high - low
                col += 1
            else:
                params[name] = np.full(m, low)
        return params, jac

    def _check_z(self, z: ArrayLike) -> NDArray:
        z = np.atleast_2d(np.asarray(z, dtype=float))
        if z.ndim != 2 or z.shape[1] != self.n_variables:
            raise ValueError(f"z: need shape (m, {self.n_variables}), got {z.shape}")
        if not np.all(np.isfinite(z)) or np.any(z < 0.0) or np.any(z > 1.0):
            raise ValueError("z: every variable must lie in [0, 1]")
        return z

    def designs(self, z: ArrayLike) -> DesignBatch:
        """The designs of the rows of ``z`` (shape ``(m, n_variables)``, in ``[0, 1]``)."""
        z = self._check_z(z)
        params, _ = self._decode(z)
        m, n = z.shape[0], self.n_units
        pad = np.full((m, MAX_UNITS - n), np.nan)
        return DesignBatch(
            n_units=np.full(m, n, dtype=np.int64),
            **{name: np.hstack([params[name], pad]) for name in _PER_UNIT},
            **{name: params[name] for name in _SHARED},
            **{name: np.full(m, float(getattr(self, name))) for name in _FIXED},
            constants=self.constants,
        )

    def design(self, z: ArrayLike) -> Design:
        """The design of one point ``z``."""
        return self.designs(np.asarray(z, dtype=float).reshape(1, -1)).design(0)

    def jacobian(self, z: ArrayLike) -> NDArray:
        """``dθ/dz`` of shape ``(m, 3N + 3, n_variables)``, rows in :attr:`parameters` order."""
        return self._decode(self._check_z(z))[1]

    def encode(self, batch: DesignBatch, *, tol: float = 1e-9) -> tuple[NDArray, NDArray]:
        """Variables ``z`` of given designs and whether each satisfies these variables.

        A design is inside when it has ``n_units`` units, its fixed parameters equal the fixed
        values, its free parameters lie in their bounds, its tied heights are equal and its
        ordered heights are ordered, all within ``tol`` (mm or MPa). ``z`` of an outside design is
        the nearest point of the box the map allows (clipped), useful only as a starting guess.

        Returns
        -------
        z : ndarray of shape (m, n_variables)
        inside : ndarray of bool, shape (m,)
        """
        m, n = len(batch), self.n_units
        inside = batch.n_units == n
        H = np.nan_to_num(batch.H[:, :n], nan=0.0)
        z = np.zeros((m, self.n_variables))
        col = 0
        slot_values = np.empty((m, len(self._slots)))
        in_chain = {s: i for i, s in enumerate(self._chain)}
        for s, slot in enumerate(self._slots):
            value = H[:, slot.units[0]]
            for u in slot.units[1:]:
                inside &= np.abs(H[:, u] - value) <= tol
            inside &= (value >= slot.low - tol) & (value <= slot.high + tol)
            value = np.clip(value, slot.low, slot.high)
            slot_values[:, s] = value
            if not slot.free:
                continue
            i = in_chain.get(s)
            if i is None or i == 0:
                a, b = slot.low, np.full(m, slot.high)
                a = np.full(m, a)
            else:
                step = self.min_step if self.heights == "ascending" else -self.min_step
                hp = slot_values[:, self._chain[i - 1]] + step
                if self.heights == "descending":
                    a, b = np.full(m, slot.low), np.minimum(slot.high, hp)
                    inside &= value <= hp + tol
                else:
                    a, b = np.maximum(slot.low, hp), np.full(m, slot.high)
                    inside &= value >= hp - tol
            width = b - a
            with np.errstate(invalid="ignore", divide="ignore"):
                w = np.where(width > 0, (value - a) / np.where(width > 0, width, 1.0), 0.5)
            z[:, col] = np.clip(w, 0.0, 1.0)
            col += 1
        for name, shared in (("U_L", self.shared_U_L), ("U_sep", self.shared_U_sep)):
            low, high = self._bounds[name]
            values = np.nan_to_num(getattr(batch, name)[:, :n], nan=-np.inf)
            inside &= np.all((values >= low - tol) & (values <= high + tol), axis=1)
            if high > low:
                scaled = np.clip((values - low) / (high - low), 0.0, 1.0)
                if shared:
                    inside &= np.all(np.abs(values - values[:, :1]) <= tol, axis=1)
                    z[:, col] = scaled[:, 0]
                    col += 1
                else:
                    z[:, col : col + n] = scaled
                    col += n
        for name in _SHARED:
            low, high = self._bounds[name]
            values = getattr(batch, name)
            inside &= (values >= low - tol) & (values <= high + tol)
            if high > low:
                z[:, col] = np.clip((values - low) / (high - low), 0.0, 1.0)
                col += 1
        for name in _FIXED:
            inside &= np.abs(getattr(batch, name) - float(getattr(self, name))) <= tol
        return z, inside

    def contains(self, batch: DesignBatch, *, tol: float = 1e-9) -> NDArray:
        """Whether each design satisfies the bounds and constraints (see :meth:`encode`)."""
        return self.encode(batch, tol=tol)[1]

    def bounds_of(self, parameter: str) -> tuple[float, float]:
        """Bounds of a model parameter (``"H_3"``, ``"U_L_1"``, ``"t"``, ``"E"``, ...)."""
        name, unit = parameter, ""
        if parameter[-1].isdigit():
            name, _, unit = parameter.rpartition("_")
        if name == "H":
            k = int(unit) - 1
            slot = next(s for s in self._slots if k in s.units)
            return slot.low, slot.high
        if name in ("U_L", "U_sep", "t", "t_lim"):
            return self._bounds[name]
        if name in _FIXED:
            value = float(getattr(self, name))
            return value, value
        raise ValueError(f"parameter = {parameter!r}: unknown; known: {self.parameters}")


def _height_bounds(value, n_units: int) -> list[tuple[float, float]]:
    """Per-unit height bounds from a number, ``[low, high]``, or one of those per unit.

    ``[low, high]`` (two numbers) is always one interval for every unit, also for two units;
    per-unit entries are written as a list of ``N`` numbers or intervals, e.g.
    ``[4.0, 4.5, 5.0, 5.0, [2.5, 5.0], [2.5, 5.0]]``, or ``[[3, 5], [3, 5]]`` for two units.
    """
    if isinstance(value, (str, bytes)):
        raise ValueError(f"H = {value!r}: give a number, [low, high] or one per unit")

    def scalar(v) -> bool:
        return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)

    if scalar(value) or (len(value) == 2 and all(scalar(v) for v in value)):
        return [_interval("H", value)] * n_units
    if len(value) != n_units:
        raise ValueError(f"H = {list(value)!r}: {len(value)} entries for {n_units} units")
    return [_interval(f"H[unit {k + 1}]", v) for k, v in enumerate(value)]
