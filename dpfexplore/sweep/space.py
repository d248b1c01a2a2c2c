"""Sweep job specifications: the design space a sweep samples and what it computes.

A job is data: a TOML file under ``jobs/`` that :func:`load_job` reads into a frozen
:class:`JobSpec`. Every problem in a job file is reported by :class:`JobSpecError` (a
``ValueError``) as one line that starts with the dotted key, e.g.
``space.variables.H.min = 6.0: greater than max = 5.0``; nothing is computed or written for a
job that does not validate.

Layout of a job file (lengths in mm, ``E`` in MPa, pressure in MPa, times in s)::

    [job]
    name = "paper-design-space"   # default output directory results/<name>
    description = "..."           # free text
    seed = 2024                   # any integer >= 0 (0 is a seed)
    samples_per_n = 1500          # designs per number of units
    sampler = "lhs"               # "lhs" (Latin hypercube) or "sobol" (scrambled Sobol')
    chunk_size = 2048             # optional: designs per chunk file
    constants = "results/constants/shell/constants.json"  # optional: a constants set file
                                  # (relative to the job file); the paper's by default

    [space]
    n_units = [2, 3, 4, 5, 6, 7]  # or {min = 2, max = 7}
    material = "cheetah-95a"      # optional preset for E and nu (MODEL.md §2)

    [space.variables]             # a number is fixed; {min, max} is sampled uniformly
    H = {min = 3.0, max = 5.0}    # per unit
    U_sep = {min = 1.0, max = 5.0}
    U_L = {min = 5.5, max = 10.0}
    t = {min = 0.5, max = 1.0}    # shared by the units
    t_lim = {min = 1.0, max = 2.0}
    # E, nu, r_b, t_ch: optional, default from the material preset / MODEL.md §2

    [space.constraints]
    heights = "free"              # "free", "ascending" (H_1 <= H_2 <= ...) or "descending"
    equal_U_sep = false           # one U_sep shared by all units of a design
    equal_U_L = false

    [compute]
    states = "all_inverted"       # "all_inverted", "sequential" (N+1 states) or "all" (2^N)
    stiffness = true              # tip stiffness of each state
    min_eig = false               # smallest Hessian eigenvalue of each state

    [compute.reset_times]         # optional: simulate the pressure cycle; reset times per unit
    P0 = 0.7                      # pressure plateau, MPa
    tau = [0.0, 1.0, 5.0, 5.1]    # tau1..tau4 of the pressure profile (MODEL.md §8), s
    t_end = 10.0                  # simulation horizon, s
    method = "rodas4"             # optional: "fast" = the fast reset model (its scene only;
    max_rel_halfwidth = 0.05      # optional, fast only: fall back where an interval is wider)

Only what ``[compute]`` asks for is computed and stored. The constants set is part of what
defines the rows: its fingerprint is in :meth:`JobSpec.result_defining`, so a sweep directory
started under one set refuses to be resumed under another (naming both).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..model.constants_set import DEFAULT, ConstantsSet, ConstantsSetError
from ..model.design import DEFAULTS, MATERIALS, resolve_constants
from ..model.domain import MAX_UNITS, RANGE_LABELS, RANGE_UNITS
from ..model.pressure import PressureProfile
from . import _jobfile as _v
from ._jobfile import JobSpecError

__all__ = [
    "PER_UNIT_VARIABLES",
    "SHARED_VARIABLES",
    "STATE_SELECTIONS",
    "ComputeSpec",
    "DesignSpace",
    "JobSpec",
    "JobSpecError",
    "PressureLoad",
    "Variable",
    "load_job",
    "parse_job",
    "recorded_space",
]

#: Variables with one value per unit (MODEL.md §2).
PER_UNIT_VARIABLES = ("H", "U_L", "U_sep")
#: Variables shared by all units of a design.
SHARED_VARIABLES = ("t", "t_lim", "E", "nu", "r_b", "t_ch")
#: Variables a job must give; the others default (material preset or MODEL.md §2).
REQUIRED_VARIABLES = ("H", "U_L", "U_sep", "t", "t_lim")
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
HEIGHT_ORDERS = ("free", "ascending", "descending")
SAMPLERS = ("lhs", "sobol")
logger = logging.getLogger(__name__)

#: Largest ``samples_per_n``: Sobol' points are limited to 2^30 per sequence, and a plan beyond
#: a billion designs per N is a typo, not a job.
MAX_SAMPLES_PER_N = 1 << 30


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
    """Where a sweep samples (see the module docstring for the job-file keys).

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
        """The job as a TOML-shaped mapping that :func:`parse_job` reads back unchanged."""
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


# ----------------------------------------------------------------------------- parsing


def load_job(path: str | Path) -> JobSpec:
    """Read and validate a job file.

    Raises
    ------
    JobSpecError
        One line naming the file and the offending key.
    """
    path = Path(path)
    try:
        with path.open("rb") as fh:
            document = tomllib.load(fh)
    except FileNotFoundError:
        raise JobSpecError(f"{path}: no such job file") from None
    except IsADirectoryError:
        raise JobSpecError(f"{path}: is a directory, not a job file") from None
    except tomllib.TOMLDecodeError as exc:
        raise JobSpecError(f"{path}: not valid TOML ({exc})") from None
    try:
        return parse_job(document, default_name=path.stem, base=path.parent)
    except JobSpecError as exc:
        raise JobSpecError(f"{path}: {exc}") from None


def parse_job(
    data: Mapping[str, Any], *, default_name: str = "job", base: str | Path | None = None
) -> JobSpec:
    """Validate a TOML-shaped mapping (see the module docstring) into a :class:`JobSpec`.

    Raises
    ------
    JobSpecError
        For an unknown or missing key, a value of the wrong type, ``min > max``, a non-finite
        or non-physical bound, or a number of units outside 1..MAX_UNITS; the message names the
        dotted key. ``job.constants`` names a constants set file, relative to ``base`` (the job
        file's folder) unless absolute; a set that cannot be read is refused here too.
    """
    _v.check_keys(data, "", required=("job", "space", "compute"), optional=())
    job = _v.table(data, "job")
    _v.check_keys(
        job,
        "job",
        required=("seed", "samples_per_n"),
        optional=("name", "description", "sampler", "chunk_size", "constants"),
    )
    name = _v.string(job, "job", "name", default=default_name)
    if not name or any(c in name for c in "/\\") or name in {".", ".."}:
        raise JobSpecError(f"job.name = {name!r}: must be a non-empty name without slashes")
    seed = _v.integer(job, "job", "seed", low=0, high=(1 << 63) - 1)
    samples = _v.integer(job, "job", "samples_per_n", low=1, high=MAX_SAMPLES_PER_N)
    sampler = _v.choice(job, "job", "sampler", SAMPLERS, default="lhs")
    chunk_size = (
        _v.integer(job, "job", "chunk_size", low=1, high=MAX_SAMPLES_PER_N)
        if "chunk_size" in job
        else None
    )
    description = _v.string(job, "job", "description", default="")
    constants, constants_file = DEFAULT, None
    if "constants" in job:
        written = _v.string(job, "job", "constants")
        try:
            constants = resolve_constants(written, base)
        except ConstantsSetError as exc:
            raise JobSpecError(f"job.constants = {written!r}: {exc}") from None
        constants_file = str(
            Path(written).expanduser()
            if Path(written).expanduser().is_absolute() or base is None
            else (Path(base) / written).resolve()
        )
    if sampler == "sobol" and samples & (samples - 1):
        logger.warning(
            "job.samples_per_n = %d is not a power of 2: a scrambled Sobol' plan of that size "
            "loses its balance properties (still a valid sample)",
            samples,
        )
    return JobSpec(
        name=name,
        seed=seed,
        samples_per_n=samples,
        space=_parse_space(_v.table(data, "space")),
        compute=_parse_compute(_v.table(data, "compute")),
        sampler=sampler,
        chunk_size=chunk_size,
        description=description,
        constants=constants,
        constants_file=constants_file,
    )


def recorded_space(job: Mapping[str, Any]) -> DesignSpace:
    """The design space of a job recorded with a dataset (:meth:`JobSpec.to_dict`).

    Only the space is read: the job's constants set file (which may have moved since) is not
    needed to know where the designs were sampled.

    Raises
    ------
    JobSpecError
        When the recorded space does not validate (naming the key).
    """
    return _parse_space(_v.table(job, "space"))


def _parse_space(space: Mapping[str, Any]) -> DesignSpace:
    _v.check_keys(
        space, "space", required=("n_units", "variables"), optional=("material", "constraints")
    )
    n_units = _parse_n_units(space["n_units"])
    material_key = None
    preset: dict[str, float] = {"E": DEFAULTS["E"], "nu": DEFAULTS["nu"]}
    if "material" in space:
        material_key = _v.string(space, "space", "material")
        if material_key.lower() not in MATERIALS:
            raise JobSpecError(
                f"space.material = {material_key!r}: unknown material; "
                f"choose one of {sorted(MATERIALS)}"
            )
        chosen = MATERIALS[material_key.lower()]
        preset = {"E": chosen.E, "nu": chosen.nu}
    variables_table = _v.table(space, "space", "variables")
    _v.check_keys(
        variables_table,
        "space.variables",
        required=REQUIRED_VARIABLES,
        optional=tuple(
            v for v in (*PER_UNIT_VARIABLES, *SHARED_VARIABLES) if v not in REQUIRED_VARIABLES
        ),
    )
    if material_key is not None and "E" in variables_table:
        raise JobSpecError(
            f"space.variables.E = {variables_table['E']!r}: give either space.material or E, "
            "not both"
        )
    defaults = {**DEFAULTS, **preset}
    variables = tuple(
        _parse_variable(name, variables_table.get(name, defaults.get(name)))
        for name in (*PER_UNIT_VARIABLES, *SHARED_VARIABLES)
    )
    constraints = space.get("constraints", {})
    if not isinstance(constraints, Mapping):
        raise JobSpecError(f"space.constraints = {constraints!r}: must be a table")
    _v.check_keys(
        constraints,
        "space.constraints",
        required=(),
        optional=("heights", "equal_U_sep", "equal_U_L"),
    )
    return DesignSpace(
        n_units=n_units,
        variables=variables,
        heights=_v.choice(
            constraints, "space.constraints", "heights", HEIGHT_ORDERS, default="free"
        ),
        equal_U_sep=_v.boolean(constraints, "space.constraints", "equal_U_sep", default=False),
        equal_U_L=_v.boolean(constraints, "space.constraints", "equal_U_L", default=False),
        material=material_key.lower() if material_key is not None else None,
    )


def _parse_n_units(value: Any) -> tuple[int, ...]:
    key = "space.n_units"
    if isinstance(value, Mapping):
        _v.check_keys(value, key, required=("min", "max"), optional=())
        low = _v.integer(value, key, "min", low=1, high=MAX_UNITS)
        high = _v.integer(value, key, "max", low=1, high=MAX_UNITS)
        if low > high:
            raise JobSpecError(f"{key}.min = {low}: greater than max = {high}")
        return tuple(range(low, high + 1))
    if isinstance(value, list):
        if not value:
            raise JobSpecError(f"{key} = []: give at least one number of units")
        counts = []
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, int):
                raise JobSpecError(f"{key}[{i}] = {item!r}: must be an integer")
            if not 1 <= item <= MAX_UNITS:
                raise JobSpecError(f"{key} = {item}: must be between 1 and {MAX_UNITS}")
            counts.append(item)
        if len(set(counts)) != len(counts):
            raise JobSpecError(f"{key} = {value!r}: lists a number of units twice")
        return tuple(sorted(counts))
    if isinstance(value, int) and not isinstance(value, bool):
        if not 1 <= value <= MAX_UNITS:
            raise JobSpecError(f"{key} = {value}: must be between 1 and {MAX_UNITS}")
        return (value,)
    raise JobSpecError(f"{key} = {value!r}: must be an integer, a list or {{min, max}}")


def _parse_variable(name: str, value: Any) -> Variable:
    key = f"space.variables.{name}"
    if isinstance(value, Mapping):
        _v.check_keys(value, key, required=("min", "max"), optional=())
        low = _bound(name, f"{key}.min", value["min"])
        high = _bound(name, f"{key}.max", value["max"])
        if low > high:
            raise JobSpecError(f"{key}.min = {low!r}: greater than max = {high!r}")
        return Variable(name, low, high)
    fixed = _bound(name, key, value)
    return Variable(name, fixed, fixed)


def _bound(name: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise JobSpecError(
            f"{key} = {value!r}: must be a number"
            + ("" if "." in key.removeprefix("space.variables.") else " or a table {min, max}")
        )
    value = float(value)
    if not math.isfinite(value):
        raise JobSpecError(f"{key} = {value!r}: must be finite")
    if name == "nu":
        if not 0.0 <= value < 0.5:
            raise JobSpecError(f"{key} = {value!r}: Poisson ratio must satisfy 0 <= nu < 0.5")
    elif value <= 0.0:
        raise JobSpecError(f"{key} = {value!r}: must be > 0 {VARIABLE_UNITS[name]}")
    return value


def _parse_compute(compute: Mapping[str, Any]) -> ComputeSpec:
    _v.check_keys(
        compute,
        "compute",
        required=("states",),
        optional=("stiffness", "min_eig", "reset_times"),
    )
    load = None
    reset = compute.get("reset_times", False)
    if isinstance(reset, Mapping):
        load = _parse_load(reset)
    elif reset is not False:
        raise JobSpecError(
            f"compute.reset_times = {reset!r}: must be false or a table "
            "[compute.reset_times] with P0, tau and t_end"
        )
    return ComputeSpec(
        states=_v.choice(compute, "compute", "states", STATE_SELECTIONS),
        stiffness=_v.boolean(compute, "compute", "stiffness", default=False),
        min_eig=_v.boolean(compute, "compute", "min_eig", default=False),
        reset_times=load,
    )


def _parse_load(table: Mapping[str, Any]) -> PressureLoad:
    key = "compute.reset_times"
    _v.check_keys(
        table, key, required=("P0", "tau", "t_end"), optional=("method", "max_rel_halfwidth")
    )
    P0 = table["P0"]
    if isinstance(P0, bool) or not isinstance(P0, (int, float)):
        raise JobSpecError(f"{key}.P0 = {P0!r}: must be a number (MPa)")
    tau_value = table["tau"]
    if not isinstance(tau_value, list) or len(tau_value) != 4:
        raise JobSpecError(f"{key}.tau = {tau_value!r}: must be a list of 4 times [tau1..tau4] (s)")
    for i, item in enumerate(tau_value):
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise JobSpecError(f"{key}.tau[{i}] = {item!r}: must be a number (s)")
    tau = [float(item) for item in tau_value]
    try:  # the one validation of pressure profiles (physical range: model/pressure.py)
        PressureProfile.pulse(float(P0), tau)
    except ValueError as exc:
        raise JobSpecError(f"{key}.{exc}") from None
    P0 = float(P0)
    t_end = _v.positive(table, key, "t_end", "s")
    if t_end <= tau[3]:
        raise JobSpecError(f"{key}.t_end = {t_end!r}: must be after tau4 = {tau[3]!r} s")
    method = _v.string(table, key, "method") if "method" in table else None
    if method is not None:
        from ..solvers.dynamics.simulate import METHODS

        batch_methods = [
            name
            for name, info in METHODS.items()
            if info.integrator >= 0 or info.model in ("release", "fast")
        ]
        if method not in batch_methods:
            raise JobSpecError(
                f"{key}.method = {method!r}: must be one of {', '.join(batch_methods)}"
            )
    width = None
    if "max_rel_halfwidth" in table:
        if method != "fast":
            raise JobSpecError(f'{key}.max_rel_halfwidth: only with method = "fast"')
        width = _v.positive(table, key, "max_rel_halfwidth", "1")
    return PressureLoad(
        P0=P0,
        tau=(tau[0], tau[1], tau[2], tau[3]),
        t_end=t_end,
        method=method,
        max_rel_halfwidth=width,
    )
