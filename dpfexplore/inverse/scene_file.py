"""Scene files: what a finger must do, as TOML; the tables every kind shares, read and validated.

Read by :func:`dpfexplore.inverse.kinds.load_scene`. A scene names its kind (one of
:data:`dpfexplore.inverse.kinds.SCENE_KINDS`), the design variables with their bounds and
constraints, the material, and the kind's own tables (its targets, objective or requirements),
read by the kind's parser in its package (``dpfexplore.inverse.scenes.<kind>.spec``). Every
problem in a scene file is one :class:`SceneSpecError` (a ``ValueError``) whose one-line message
starts with the dotted key, e.g. ``variables.H.min = 6.0: greater than max = 5.0``; nothing is
computed or written for a scene that does not validate.

The shared tables (lengths in mm, ``E`` in MPa; model frame of MODEL.md §5)::

    [scene]
    kind = "position"             # one of dpfexplore.inverse.kinds.SCENE_KINDS
    name = "design-position-cheetah"   # default output directory results/<name>
    description = "..."           # free text
    material = "cheetah-95a"      # or "ninjaflex-85a"; or give E (and nu) instead
    seed = 0                      # Latin hypercube seed (any integer >= 0)
    constants = "results/constants/shell/constants.json"  # optional: a constants set file,
                                  # relative to the scene file (default: the paper's forms)

    [variables]                   # -> dpfexplore.model.variables.DesignVariables, per N
    n_units = {min = 2, max = 8}  # or a list [3, 4], or one number
    H = {min = 3.0, max = 5.0}    # a number (fixed), {min, max}, or one of those per unit
    U_L = {min = 5.5, max = 10.0} # a number or {min, max}
    U_sep = {min = 1.0, max = 5.0}
    t = {min = 0.5, max = 1.0}
    t_lim = {min = 1.0, max = 2.0}
    heights = "descending"        # "free", "ascending" (H_{k+1} >= H_k) or "descending"
    ordered_units = [1, 2, 3, 4]  # optional: the units the order covers (default all)
    tied = [[5, 6]]               # optional: groups of units with one shared height
    min_step = 0.0                # optional: least difference of consecutive ordered heights
    shared_U_L = true             # one U_L for all units (default) or one per unit
    shared_U_sep = true

    [optimiser]                   # all optional
    candidates_per_n = 64         # Latin-hypercube candidates per N
    starts_per_n = 3              # gradient refinements per N before a target is declared
                                  # unreachable (the proof of unreachability)
    max_iter = 60                 # iterations per refinement
    seeds = "results/design-seeds-descending"   # optional (position kinds): candidates from
                                  # this sweep dataset's nearest tips instead of a Latin
                                  # hypercube (dpfexplore.inverse.engine.seeds); path from the cwd
    seeds_per_n = 8               # seeds per N

A kind that describes its variables itself (the walker leg: one set per section) has no
``[variables]`` table. Each kind's own tables are in the docstring of its ``spec`` module,
``dpfexplore.inverse.scenes.<kind>.spec`` (e.g. :mod:`dpfexplore.inverse.scenes.position.spec`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..io.toml_fields import (
    boolean,
    bound,
    check_keys,
    integer_in,
    plain,
    positive_number,
    read_toml,
    reported_as,
    string,
    table,
)
from ..model import status as st
from ..model.constants_set import DEFAULT
from ..model.design import MATERIALS, Design, resolve_constants
from ..model.domain import MAX_UNITS
from ..model.variables import HEIGHT_ORDERS, DesignVariables
from ..sweep.job_file import JobSpecError
from .engine.settings import OptimiserSettings
from .spec import SceneCommon, SceneSpec

__all__ = ["SceneSpecError", "build_spec", "check_seeds", "read_scene_file", "reference_design"]


class SceneSpecError(JobSpecError):
    """A scene file that does not validate; the message is one line naming the key."""


def read_scene_file(path: str | Path) -> dict[str, Any]:
    """The TOML document of a scene file (:class:`SceneSpecError` if unreadable)."""
    path = Path(path)
    try:
        with reported_as(SceneSpecError):
            return read_toml(path, "scene")
    except OSError as exc:
        raise SceneSpecError(f"{path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SceneSpecError(f"{path}: not a text file (a scene is TOML)") from None


@reported_as(SceneSpecError)
def build_spec(
    data: Mapping[str, Any],
    *,
    kind: str,
    tables: Sequence[str],
    own_variables: bool,
    parse: Callable[[Mapping[str, Any], SceneCommon], Any],
    default_name: str = "scene",
    base: str | Path | None = None,
) -> SceneSpec:
    """Validate a TOML-shaped scene of a known ``kind`` into a :class:`SceneSpec`.

    The parts every kind shares (``[scene]``, ``[variables]``, ``[optimiser]``) are read here
    into a :class:`SceneCommon`; ``parse`` reads the kind's own tables (``tables``) and returns
    its kind spec. A kind with ``own_variables`` has no ``[variables]`` table: its kind spec's
    ``n_units`` are the scene's. The table of kinds, and the entry points
    :func:`~dpfexplore.inverse.kinds.load_scene` / :func:`~dpfexplore.inverse.kinds.parse_scene`,
    are in :mod:`dpfexplore.inverse.kinds`. ``scene.constants`` names a constants set file
    relative to ``base`` (the scene file's folder); every design the scene makes, reference
    designs included, runs on it.
    """
    own = own_variables
    check_keys(
        data,
        "",
        required=("scene",) if own else ("scene", "variables"),
        optional=("optimiser", *tables),
    )
    scene = table(data, "scene")
    check_keys(
        scene,
        "scene",
        required=("kind",),
        optional=("name", "description", "material", "E", "nu", "seed", "constants"),
    )
    name = string(scene, "scene", "name", default=default_name)
    if not name.strip() or "/" in name or "\\" in name or name in (".", ".."):
        # the name is the default --out folder: it must name a folder of its own
        raise SceneSpecError(
            f"scene.name = {name!r}: need a non-empty name without '/', other than '.' and '..'"
        )
    seed = scene.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SceneSpecError(f"scene.seed = {seed!r}: must be an integer >= 0")
    E, nu, material = _material(scene)
    constants = DEFAULT
    if "constants" in scene:
        written = string(scene, "scene", "constants", default="")
        try:
            constants = resolve_constants(written, base)
        except ValueError as exc:
            raise SceneSpecError(f"scene.constants = {written!r}: {exc}") from None
    n_units, variables = ((), {}) if own else _variables(table(data, "variables"))
    common = SceneCommon(
        kind=kind,
        name=name,
        description=string(scene, "scene", "description", default=""),
        seed=seed,
        E=E,
        nu=nu,
        material=material,
        n_units=n_units,
        variables=variables,
        optimiser=_optimiser(data.get("optimiser", {})),
        document=plain(data),
        constants=constants,
    )
    kind_spec = parse(data, common)
    if own:
        common = replace(common, n_units=tuple(kind_spec.n_units))
    spec = SceneSpec.of(common, kind_spec)
    for n in () if own else spec.n_units:
        try:
            variables = spec.design_variables(n)
        except ValueError as exc:
            raise SceneSpecError(f"variables (N = {n}): {exc}") from None
        _check_box_holds_designs(variables)
    return spec


#: Points of a scene's variable box sampled when it is read, to show that it holds valid
#: designs before any optimisation starts (0.1 ms per point).
BOX_PROBES = 512


def _check_box_holds_designs(variables: DesignVariables) -> None:
    from scipy.stats import qmc

    if variables.n_variables == 0:
        z = np.zeros((1, 0))
    else:
        z = qmc.LatinHypercube(d=variables.n_variables, seed=0).random(BOX_PROBES)
    codes, problems = variables.designs(z).problems()
    if not np.any(codes == st.OK):
        example = next(p for p in problems if p)
        raise SceneSpecError(
            f"variables (N = {variables.n_units}): the box holds no valid design (none of "
            f"{len(z)} sampled over it), e.g. {example}"
        )


# ----------------------------------------------------------------------------- pieces


def _variables(given: Mapping[str, Any]) -> tuple[tuple[int, ...], dict[str, Any]]:
    check_keys(
        given,
        "variables",
        required=("n_units", "H", "U_L", "U_sep", "t", "t_lim"),
        optional=("heights", "ordered_units", "tied", "shared_U_L", "shared_U_sep", "min_step"),
    )
    n_units = _n_units(given["n_units"])
    out: dict[str, Any] = {}
    H = given["H"]
    if isinstance(H, list):
        if len(n_units) != 1 or len(H) != n_units[0]:
            raise SceneSpecError(
                f"variables.H = {H!r}: one entry per unit needs one N (variables.n_units) and "
                f"{n_units[0] if len(n_units) == 1 else 'N'} entries"
            )
        out["H"] = [bound(v, f"variables.H[{k}]") for k, v in enumerate(H)]
    else:
        out["H"] = bound(H, "variables.H")
    for name in ("U_L", "U_sep", "t", "t_lim"):
        out[name] = bound(given[name], f"variables.{name}")
    heights = given.get("heights", "free")
    if heights not in HEIGHT_ORDERS:
        raise SceneSpecError(
            f"variables.heights = {heights!r}: must be one of {', '.join(HEIGHT_ORDERS)}"
        )
    out["heights"] = heights
    if "ordered_units" in given:
        units = given["ordered_units"]
        if (
            not isinstance(units, list)
            or not units
            or not all(
                isinstance(u, int) and not isinstance(u, bool) and 1 <= u <= MAX_UNITS
                for u in units
            )
        ):
            raise SceneSpecError(f"variables.ordered_units = {units!r}: need unit numbers")
        if any(u > min(n_units) for u in units):
            raise SceneSpecError(
                f"variables.ordered_units = {units!r}: unit beyond N = {min(n_units)}"
            )
        out["ordered_units"] = tuple(units)
    if "tied" in given:
        tied = given["tied"]
        if not isinstance(tied, list) or not all(
            isinstance(g, list) and all(isinstance(u, int) and not isinstance(u, bool) for u in g)
            for g in tied
        ):
            raise SceneSpecError(f"variables.tied = {tied!r}: need lists of unit numbers")
        out["tied"] = tuple(tuple(g) for g in tied)
    if "min_step" in given:
        step = given["min_step"]
        if (
            isinstance(step, bool)
            or not isinstance(step, (int, float))
            or not math.isfinite(step)
            or step < 0
        ):
            raise SceneSpecError(f"variables.min_step = {step!r}: must be a number >= 0 mm")
        out["min_step"] = float(step)
    for name in ("shared_U_L", "shared_U_sep"):
        out[name] = boolean(given, "variables", name, default=True)
    return n_units, out


def _n_units(value: Any) -> tuple[int, ...]:
    where = "variables.n_units"

    def unit(v: Any) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_UNITS:
            raise SceneSpecError(f"{where} = {value!r}: need integers between 1 and {MAX_UNITS}")
        return v

    if isinstance(value, Mapping):
        check_keys(value, where, required=("min", "max"), optional=())
        low, high = unit(value["min"]), unit(value["max"])
        if low > high:
            raise SceneSpecError(f"{where} = {{min = {low}, max = {high}}}: empty range")
        return tuple(range(low, high + 1))
    if isinstance(value, list):
        if not value:
            raise SceneSpecError(f"{where} = []: empty range")
        return tuple(sorted({unit(v) for v in value}))
    return (unit(value),)


def _material(scene: Mapping[str, Any]) -> tuple[float, float, str]:
    if "material" in scene:
        if "E" in scene:
            raise SceneSpecError(f"scene.E = {scene['E']!r}: give either material or E")
        key = scene["material"]
        if not isinstance(key, str) or key.lower() not in MATERIALS:
            raise SceneSpecError(
                f"scene.material = {key!r}: must be one of {', '.join(sorted(MATERIALS))}"
            )
        preset = MATERIALS[key.lower()]
        return preset.E, _poisson(scene, preset.nu), key.lower()
    if "E" not in scene:
        raise SceneSpecError("scene.material: missing; give material or E")
    return positive_number(scene, "scene", "E", 26.0), _poisson(scene, 0.35), ""


def _poisson(scene: Mapping[str, Any], default: float) -> float:
    nu = positive_number(scene, "scene", "nu", default, allow_zero=True)
    if not nu < 0.5:
        raise SceneSpecError(f"scene.nu = {nu!r}: a Poisson ratio must be in [0, 0.5)")
    return nu


def reference_design(
    value: Any, where: str, common: SceneCommon, *, extra: tuple[str, ...] = ()
) -> tuple[Design, dict[str, float]]:
    """A reference design of a scene (a table of design keys), with the scene's material.

    ``extra`` names keys of the table that are not design keys (finite numbers, returned apart:
    e.g. the gripper's base). The scene's constants set applies; a table naming another is
    refused.
    """
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table of design keys")
    data = {k: v for k, v in value.items() if k not in extra}
    data.setdefault("E", common.E)
    data.setdefault("nu", common.nu)
    if "constants" in data:
        raise SceneSpecError(
            f"{where}.constants: the scene's constants set applies (scene.constants)"
        )
    data["constants"] = common.constants
    try:
        design = Design.from_dict(data)
    except (TypeError, ValueError) as exc:
        raise SceneSpecError(f"{where}: {exc}") from None
    values = {}
    for key in extra:
        if key in value:
            v = value[key]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise SceneSpecError(f"{where}.{key} = {v!r}: must be a finite number")
            values[key] = float(v)
    return design, values


def _optimiser(value: Any) -> OptimiserSettings:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"optimiser = {value!r}: must be a table")
    check_keys(
        value,
        "optimiser",
        required=(),
        optional=("candidates_per_n", "starts_per_n", "max_iter", "seeds", "seeds_per_n"),
    )
    default = OptimiserSettings()
    seeds = check_seeds(value["seeds"], "optimiser.seeds") if "seeds" in value else None
    counts = {
        key: integer_in(value, "optimiser", key, default=getattr(default, key), low=low, high=high)
        for key, (low, high) in (
            ("candidates_per_n", (2, 1 << 20)),
            ("starts_per_n", (1, 1000)),
            ("max_iter", (1, 10000)),
            ("seeds_per_n", (1, 10000)),
        )
    }
    return OptimiserSettings(seeds=seeds, **counts)


def check_seeds(value: Any, where: str) -> str:
    """A seeds dataset path: a string naming a sweep directory (its ``_manifest.json``)."""
    if not isinstance(value, str) or not value:
        raise SceneSpecError(f"{where} = {value!r}: must be the path of a sweep dataset")
    if not (Path(value) / "_manifest.json").is_file():
        raise SceneSpecError(
            f"{where} = {value!r}: not a sweep dataset (no _manifest.json); make it with "
            "`dpfexplore sweep JOB --out DIR`, e.g. jobs/design-seeds-descending.toml"
        )
    return value
