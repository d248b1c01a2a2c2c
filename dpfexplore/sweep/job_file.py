"""Sweep job files: the TOML format, read and validated into a :class:`~.space.JobSpec`.

A job is data: a TOML file under ``jobs/`` that :func:`load_job` reads into a frozen
:class:`~.space.JobSpec`. Every problem in a job file is reported by :class:`JobSpecError` (a
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
defines the rows: its fingerprint is in :meth:`~.space.JobSpec.result_defining`, so a sweep
directory started under one set refuses to be resumed under another (naming both).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..io import toml_fields as _v
from ..io.toml_fields import FieldError, reported_as
from ..model.constants_set import DEFAULT, ConstantsSetError, locate_constants_set
from ..model.design import DEFAULTS, MATERIALS, resolve_constants
from ..model.domain import MAX_UNITS
from ..model.pressure import PressureProfile
from ..model.variables import HEIGHT_ORDERS
from .space import (
    PER_UNIT_VARIABLES,
    SHARED_VARIABLES,
    STATE_SELECTIONS,
    VARIABLE_UNITS,
    ComputeSpec,
    DesignSpace,
    JobSpec,
    PressureLoad,
    Variable,
)

__all__ = ["JobSpecError", "load_job", "parse_job", "recorded_space"]


class JobSpecError(FieldError):
    """A job file that does not validate; the message is one line naming the key."""


#: Variables a job must give; the others default (material preset or MODEL.md §2).
REQUIRED_VARIABLES = ("H", "U_L", "U_sep", "t", "t_lim")
SAMPLERS = ("lhs", "sobol")
logger = logging.getLogger(__name__)

#: Largest ``samples_per_n``: Sobol' points are limited to 2^30 per sequence, and a plan beyond
#: a billion designs per N is a typo, not a job.
MAX_SAMPLES_PER_N = 1 << 30


#: Files of other commands a user may hand ``sweep`` by mistake: their top table, their kind and
#: the command that reads them.
_OTHER_FILES = (
    ("scene", "scene", "dpfexplore design"),
    ("design", "design", "dpfexplore states"),
)


def load_job(path: str | Path) -> JobSpec:
    """Read and validate a job file.

    Raises
    ------
    JobSpecError
        One line naming the file and the offending key.
    """
    path = Path(path)
    try:
        with reported_as(JobSpecError):
            document = _v.read_toml(path, "job")
    except FileNotFoundError:
        raise JobSpecError(f"{path}: no such job file") from None
    except IsADirectoryError:
        raise JobSpecError(f"{path}: is a directory, not a job file") from None
    if isinstance(document, Mapping) and "job" not in document:
        # another command's file: name the command that reads it
        for table, kind, command in _OTHER_FILES:
            if table in document:
                raise JobSpecError(
                    f"{path}: a {kind} file ([{table}] table), not a sweep job ([job], [space], "
                    f"[compute]); run it with: {command} {path}"
                )
    try:
        return parse_job(document, default_name=path.stem, base=path.parent)
    except JobSpecError as exc:
        raise JobSpecError(f"{path}: {exc}") from None


@reported_as(JobSpecError)
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
        located = locate_constants_set(written, base)
        constants_file = (
            None
            if located is None
            else str(located if located.is_absolute() or base is None else located.resolve())
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


@reported_as(JobSpecError)
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
                f"choose one of {', '.join(sorted(MATERIALS))}"
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
