"""What a sweep job is: the design space it samples and what it computes, as frozen records.

:class:`JobSpec` holds a validated job: its :class:`DesignSpace` (numbers of units, one
:class:`Variable` per design variable, fixed or sampled uniformly, and the constraints between
units), its :class:`ComputeSpec` (the states, stiffness, eigenvalues and reset times under a
:class:`PressureLoad`) and the constants set every design runs on. Job files are read into these
records by :mod:`dpfexplore.sweep.job_file` (the format is in its docstring).

The constants set is part of what defines the rows: its fingerprint is in
:meth:`JobSpec.result_defining`, so a sweep directory started under one set refuses to be resumed
under another (naming both).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.domain import RANGE_LABELS, RANGE_UNITS

__all__ = [
    "PER_UNIT_VARIABLES",
    "SHARED_VARIABLES",
    "STATE_SELECTIONS",
    "ComputeSpec",
    "DesignSpace",
    "JobSpec",
    "PressureLoad",
    "Variable",
]

#: Variables with one value per unit (MODEL.md §2).
PER_UNIT_VARIABLES = ("H", "U_L", "U_sep")
#: Variables shared by all units of a design.
SHARED_VARIABLES = ("t", "t_lim", "E", "nu", "r_b", "t_ch")
#: Physical unit of each variable, for messages and stored field metadata.
VARIABLE_UNITS = {
    "H": "mm",
    "U_L": "mm",
    "U_sep": "mm",
    "t": "mm",
    "t_lim": "mm",
    "E": "MPa",
    "nu": "1",
    "r_b": "mm",
    "t_ch": "mm",
}
#: Values of ``compute.states`` (the state selections of
#: :func:`dpfexplore.solvers.statics.solve_batch`).
STATE_SELECTIONS = ("all_inverted", "sequential", "all")


@dataclass(frozen=True)
class Variable:
    """One design variable: fixed (``low == high``) or sampled uniformly in ``[low, high]``.

    Attributes
    ----------
    name : str
        ``"H"``, ``"U_L"``, ``"U_sep"``, ``"t"``, ``"t_lim"``, ``"E"``, ``"nu"``, ``"r_b"`` or
        ``"t_ch"``.
    low, high : float
        Bounds in the variable's unit (:data:`VARIABLE_UNITS`).
    """

    name: str
    low: float
    high: float

    @property
    def sampled(self) -> bool:
        """Whether the variable spans a range (and so takes sampling dimensions)."""
        return self.high > self.low

    @property
    def per_unit(self) -> bool:
        """Whether the variable has one value per unit."""
        return self.name in PER_UNIT_VARIABLES

    def to_toml(self) -> float | dict[str, float]:
        """The job-file form: a number when fixed, ``{min, max}`` when sampled."""
        return {"min": self.low, "max": self.high} if self.sampled else self.low


@dataclass(frozen=True)
class DesignSpace:
    """Where a sweep samples (the job-file keys are in :mod:`~.job_file`).

    Attributes
    ----------
    n_units : tuple of int
        Numbers of units, ascending, each in 1..MAX_UNITS.
    variables : tuple of Variable
        Every variable of :data:`PER_UNIT_VARIABLES` and :data:`SHARED_VARIABLES`, in that order.
    heights : {"free", "ascending", "descending"}
        Order constraint on the dome heights of a design (unit 1 is at the base).
    equal_U_sep, equal_U_L : bool
        One value shared by all units of a design instead of one per unit.
    material : str or None
        Material preset the job named (its ``E`` and ``nu`` are in ``variables``).
    """

    n_units: tuple[int, ...]
    variables: tuple[Variable, ...]
    heights: str = "free"
    equal_U_sep: bool = False
    equal_U_L: bool = False
    material: str | None = None

    def variable(self, name: str) -> Variable:
        """The variable called ``name``."""
        for variable in self.variables:
            if variable.name == name:
                return variable
        raise KeyError(name)

    def shared_across_units(self, name: str) -> bool:
        """Whether per-unit variable ``name`` takes one value for all units of a design."""
        return {"U_sep": self.equal_U_sep, "U_L": self.equal_U_L}.get(name, False)


@dataclass(frozen=True)
class PressureLoad:
    """Pressure profile and horizon of the reset-time simulations (MODEL.md §8).

    Attributes
    ----------
    P0 : float, MPa
        Plateau pressure.
    tau : tuple of 4 float, s
        ``tau1 <= tau2 <= tau3 <= tau4``: ramp start, plateau start, release start, release end.
    t_end : float, s
        Simulation horizon (absolute time, > ``tau4``); a unit that has not reset by then gets
        a reset time of ``inf``.
    method : str or None
        Integrator of :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch` (None: its
        default); ``"fast"`` is the fast reset model
        (:mod:`dpfexplore.solvers.dynamics.fast_reset`), which adds each unit's 90 % interval
        and a per-design fallback flag to the dataset.
    max_rel_halfwidth : float or None
        ``"fast"`` only: designs with a wider relative interval run the full model.
    """

    P0: float
    tau: tuple[float, float, float, float]
    t_end: float
    method: str | None = None
    max_rel_halfwidth: float | None = None


@dataclass(frozen=True)
class ComputeSpec:
    """What a sweep computes for each design; nothing else is computed or stored.

    Attributes
    ----------
    states : {"all_inverted", "sequential", "all"}
        Which stable states to solve: the state with every unit inverted, the N+1 states of
        sequential activation, or all ``2^N`` states.
    stiffness : bool
        Tip stiffness of each state (N/mm).
    min_eig : bool
        Smallest Hessian eigenvalue of each state (N/mm).
    reset_times : PressureLoad or None
        Simulate the pressure cycle of every valid design and store each unit's snap and
        reset times and its class in the finger (bistable units report ``inf``). No static
        screen is safe: a dome that is bistable in isolation (``alpha < 1/9``) can still
        reset inside its finger, whose bending stiffness adds to its restoring force.
    """

    states: str = "all_inverted"
    stiffness: bool = False
    min_eig: bool = False
    reset_times: PressureLoad | None = None


@dataclass(frozen=True)
class JobSpec:
    """A validated sweep job.

    Attributes
    ----------
    name : str
        Job name (default output directory ``results/<name>``).
    seed : int
        Seed of the sample plan (>= 0; 0 is a seed like any other).
    samples_per_n : int
        Designs per number of units.
    space : DesignSpace
    compute : ComputeSpec
    sampler : {"lhs", "sobol"}
    chunk_size : int or None
        Designs per chunk file (None: chosen from the states requested, see
        :func:`dpfexplore.sweep.chunks.default_chunk_size`).
    description : str
    constants : ConstantsSet
        The closed forms every design is evaluated under (the paper's by default).
    constants_file : str or None
        Where the set was read from (an absolute path; None for the paper's set).
    """

    name: str
    seed: int
    samples_per_n: int
    space: DesignSpace
    compute: ComputeSpec
    sampler: str = "lhs"
    chunk_size: int | None = None
    description: str = ""
    constants: ConstantsSet = DEFAULT
    constants_file: str | None = None

    @property
    def n_designs(self) -> int:
        """Number of designs in the whole sweep."""
        return self.samples_per_n * len(self.space.n_units)

    @property
    def max_units(self) -> int:
        """Largest number of units in the sweep (sets the per-unit columns of the dataset)."""
        return max(self.space.n_units)

    def to_dict(self) -> dict[str, Any]:
        """The job as a TOML-shaped mapping that :func:`~.job_file.parse_job` reads back as is."""
        space = self.space
        job: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "seed": self.seed,
            "samples_per_n": self.samples_per_n,
            "sampler": self.sampler,
        }
        if self.chunk_size is not None:
            job["chunk_size"] = self.chunk_size
        if self.constants_file is not None:
            job["constants"] = self.constants_file
        compute: dict[str, Any] = {
            "states": self.compute.states,
            "stiffness": self.compute.stiffness,
            "min_eig": self.compute.min_eig,
        }
        load = self.compute.reset_times
        if load is not None:
            compute["reset_times"] = {"P0": load.P0, "tau": list(load.tau), "t_end": load.t_end}
            if load.method is not None:
                compute["reset_times"]["method"] = load.method
            if load.max_rel_halfwidth is not None:
                compute["reset_times"]["max_rel_halfwidth"] = load.max_rel_halfwidth
        space_dict: dict[str, Any] = {
            "n_units": list(space.n_units),
            "variables": {v.name: v.to_toml() for v in space.variables},
            "constraints": {
                "heights": space.heights,
                "equal_U_sep": space.equal_U_sep,
                "equal_U_L": space.equal_U_L,
            },
        }
        return {"job": job, "space": space_dict, "compute": compute}

    def result_defining(self) -> dict[str, Any]:
        """The part of :meth:`to_dict` that determines the stored rows.

        Name, description and chunk size are left out: a renamed job file, or a different chunk
        size, produces the same rows (sampling and evaluation are chunk-invariant).
        """
        data = self.to_dict()
        job = data["job"]
        return {
            "job": {k: job[k] for k in ("seed", "samples_per_n", "sampler")},
            "space": data["space"],
            "compute": data["compute"],
            "constants": {
                "name": self.constants.name,
                "fingerprint": self.constants.fingerprint,
            },
        }

    def fitted_range_note(self) -> str | None:
        """One line naming the quantities whose range leaves the constants set's domain.

        The set's :attr:`~dpfexplore.model.constants_set.ConstantsSet.domain` (for the paper's,
        :data:`dpfexplore.model.domain.FITTED_RANGES`); None when the whole space is inside.
        Which rows are outside is in each row's ``fitted_range`` column.
        """
        parts = []
        for name, (low, high) in self.constants.domain.items():
            lo, hi = self._span(name)
            if lo < low or hi > high:
                unit = RANGE_UNITS.get(name, "")
                unit = f" {unit}" if unit else ""
                span = f"{lo:g}" + (f"-{hi:g}" if hi > lo else "")
                fitted = f"{low:g}" if low == high else f"{low:g}-{high:g}"
                parts.append(f"{RANGE_LABELS.get(name, name)} {span}{unit} (fitted {fitted}{unit})")
        return "; ".join(parts) if parts else None

    def _span(self, name: str) -> tuple[float, float]:
        """The range of a quantity a domain may bound over the job's space."""
        if name in ("H_over_rb", "t_over_rb"):
            length, r_b = self.space.variable(name[0]), self.space.variable("r_b")
            return length.low / r_b.high, length.high / r_b.low
        variable = self.space.variable(name)
        return variable.low, variable.high

    def fingerprint(self) -> str:
        """SHA-256 of :meth:`result_defining` in canonical JSON: equal iff the rows are equal."""
        canonical = json.dumps(self.result_defining(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(canonical.encode()).hexdigest()

    def first_difference(self, other: Mapping[str, Any]) -> str | None:
        """Dotted key of the first result-defining value that differs from ``other``.

        ``other`` is the :meth:`result_defining` mapping of another job (as stored in a sweep
        directory's manifest). Returns None when they agree.
        """
        return _first_difference(self.result_defining(), other, "")


def _first_difference(a: Any, b: Any, prefix: str) -> str | None:
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        for key in sorted(set(a) | set(b)):
            where = f"{prefix}.{key}" if prefix else str(key)
            if key not in a or key not in b:
                return where
            found = _first_difference(a[key], b[key], where)
            if found is not None:
                return found
        return None
    return None if a == b else (prefix or "<job>")
