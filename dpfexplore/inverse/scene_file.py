"""Scene files: what a finger must do, as TOML, read and validated into a SceneSpec.

Read by :func:`dpfexplore.inverse.kinds.load_scene`. A scene names its kind (one of
:data:`dpfexplore.inverse.kinds.SCENE_KINDS`), its targets, the design variables with their
bounds and constraints, the material and the objective's weights or tolerances
(:class:`~.spec.SceneSpec`). Every problem in
a scene file is one :class:`SceneSpecError` (a ``ValueError``) whose one-line message starts with
the dotted key, e.g. ``variables.H.min = 6.0: greater than max = 5.0``; nothing is computed or
written for a scene that does not validate.

Layout (lengths in mm, ``E`` in MPa, pressure in MPa, times in s; model frame of MODEL.md §5)::

    [scene]
    kind = "position"             # "position", "position_stiffness" or "gripper"
                                  # ("pickplace", "walker_leg": inverse.scenes.timing_spec)
    name = "design-position-cheetah"   # default output directory results/<name>
    description = "..."           # free text
    material = "cheetah-95a"      # or "ninjaflex-85a"; or give E (and nu) instead
    seed = 0                      # Latin hypercube seed (any integer >= 0)
    constants = "results/constants/shell/constants.json"  # optional: a constants set file,
                                  # relative to the scene file (default: the paper's forms)

    [variables]                   # -> dpfexplore.sweep.variables.DesignVariables, per N
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

    [[targets]]                   # position, position_stiffness: one table per target
    point = [46.0, 32.0]          # tip (x, y) of the targeted state, mm
    reference = {H = [...], U_L = 9.98, U_sep = 2.26, t = 0.9, t_lim = 1.89}  # optional:
                                  # a design to compare with (e.g. the paper's), material's E

    [objective]
    state = "all_inverted"        # position kinds: the targeted state ("all_inverted" or bits
                                  # when N is fixed)
    tolerance = 1e-6              # mm²: a target is met when |tip - target|² <= tolerance
    # position_stiffness only:
    front = [0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0]   # tip tolerances of the front, mm
    weights = [1.0, 1.0]          # optional: also solve the paper's w1 |r|² + w2 (1/K)²

    [optimiser]                   # all optional
    candidates_per_n = 64         # Latin-hypercube candidates per N
    starts_per_n = 3              # gradient refinements per N before a target is declared
                                  # unreachable (the proof of unreachability)
    max_iter = 60                 # iterations per refinement
    seeds = "results/design-seeds-descending"   # optional (position kinds): candidates from
                                  # this sweep dataset's nearest tips instead of a Latin
                                  # hypercube (dpfexplore.inverse.engine.seeds); path from the cwd
    seeds_per_n = 8               # seeds per N

    [gripper]                     # kind = "gripper" (MODEL.md §7, §9)
    states = ["10000", "11000", "11100", "11110"]
    apertures = [70.0, 60.0, 45.0, 35.0]   # mm, one per state
    aperture_tol = 0.05           # mm
    activated = "11110"           # the state whose tip stiffness is maximised
    theta_B_deg = {min = -60.0, max = 0.0}
    base_L = {min = 5.0, max = 40.0}
    min_window_kPa = 10.0         # each state's pressure window under a slow ramp
    metastable_unit = 5           # must reset, after >= min_reset_s, under the pulse
    min_reset_s = 0.05
    pulse = {P0 = 0.7, tau = [0.0, 0.5, 1.0, 1.1], t_end = 2.0}
    reference = {H = [...], ..., theta_B_deg = -27.065, base_L = 20.081}   # optional

Every kind is one record of the literal table :data:`dpfexplore.inverse.kinds.SCENE_KINDS`: its
own tables, whether it describes its variables itself (the walker leg: one set per section), its
parser (here for the position and gripper kinds, in :mod:`dpfexplore.inverse.scenes.timing_spec`
for the timing kinds), its solver, report and writer.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from ..model import status as st
from ..model.constants_set import DEFAULT
from ..model.design import MATERIALS, Design, resolve_constants
from ..model.domain import MAX_UNITS
from ..model.pressure import PressureProfile
from ..model.variables import HEIGHT_ORDERS, DesignVariables
from .spec import GripperSpec, OptimiserSettings, SceneSpec, Target
from .spec_fields import (
    SceneSpecError,
    _bound,
    _keys,
    _numbers,
    _plain,
    _positive,
    _range,
    _string,
    _table,
)

__all__ = [
    "build_spec",
    "check_seeds",
    "parse_gripper",
    "parse_position",
    "read_scene_file",
    "with_seeds",
]

#: Farthest tip target accepted (mm along either axis): far beyond any finger of MAX_UNITS
#: units, near enough that squared distances stay finite (1e300 mm overflowed to inf).
MAX_TARGET_DISTANCE = 1000.0


def read_scene_file(path: str | Path) -> dict[str, Any]:
    """The TOML document of a scene file (:class:`SceneSpecError` if unreadable)."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except OSError as exc:
        raise SceneSpecError(f"{path}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneSpecError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise SceneSpecError(f"{path}: not a text file (a scene is TOML)") from None


def build_spec(
    data: Mapping[str, Any],
    *,
    kind: str,
    tables: Sequence[str],
    own_variables: bool,
    parse: Callable[[Mapping[str, Any], dict[str, Any]], dict[str, Any]],
    default_name: str = "scene",
    base: str | Path | None = None,
) -> SceneSpec:
    """Validate a TOML-shaped scene of a known ``kind`` into a :class:`SceneSpec`.

    The parts every kind shares (``[scene]``, ``[variables]``, ``[optimiser]``) are read here;
    ``parse`` reads the kind's own tables (``tables``) and returns the fields it adds. The
    table of kinds, and the entry points :func:`~dpfexplore.inverse.kinds.load_scene` /
    :func:`~dpfexplore.inverse.kinds.parse_scene`, are in :mod:`dpfexplore.inverse.kinds`.
    ``scene.constants`` names a constants set file relative to ``base`` (the scene file's
    folder); every design the scene makes, reference designs included, runs on it.
    """
    own = own_variables
    _keys(
        data,
        "",
        required=("scene",) if own else ("scene", "variables"),
        optional=("optimiser", *tables),
    )
    scene = _table(data, "scene")
    _keys(
        scene,
        "scene",
        required=("kind",),
        optional=("name", "description", "material", "E", "nu", "seed", "constants"),
    )
    name = _string(scene, "scene", "name", default_name)
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
        written = _string(scene, "scene", "constants", "")
        try:
            constants = resolve_constants(written, base)
        except ValueError as exc:
            raise SceneSpecError(f"scene.constants = {written!r}: {exc}") from None
    n_units, variables = ((), {}) if own else _variables(_table(data, "variables"))
    fields = dict(
        kind=kind,
        name=name,
        description=_string(scene, "scene", "description", ""),
        seed=seed,
        E=E,
        nu=nu,
        material=material,
        n_units=n_units,
        variables=variables,
        optimiser=_optimiser(data.get("optimiser", {})),
        document=_plain(data),
        constants=constants,
    )
    fields.update(parse(data, fields))
    spec = SceneSpec(**fields)
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


def parse_position(data: Mapping[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """The fields of a position (or position-and-stiffness) scene: targets and objective."""
    stiffness = fields["kind"] == "position_stiffness"
    if "gripper" in data:
        raise SceneSpecError(f"gripper = {{...}}: unknown table for kind {fields['kind']!r}")
    if "targets" not in data:
        raise SceneSpecError("targets: missing; give [[targets]] tables with point = [x, y]")
    raw = data["targets"]
    if not isinstance(raw, list) or not raw or not all(isinstance(t, Mapping) for t in raw):
        raise SceneSpecError("targets: need one or more [[targets]] tables")
    targets = []
    for i, entry in enumerate(raw):
        where = f"targets[{i}]"
        _keys(entry, where, required=("point",), optional=("reference",))
        point = _numbers(entry["point"], f"{where}.point", length=2, unit="mm")
        if max(abs(point[0]), abs(point[1])) > MAX_TARGET_DISTANCE:
            raise SceneSpecError(
                f"{where}.point = {list(point)}: more than {MAX_TARGET_DISTANCE:g} mm from the "
                "base; no finger of this model reaches that far"
            )
        reference = None
        if "reference" in entry:
            reference = _design(entry["reference"], f"{where}.reference", fields, extra=())[0]
        targets.append(Target(point=(point[0], point[1]), reference=reference))
    objective = data.get("objective", {})
    if not isinstance(objective, Mapping):
        raise SceneSpecError(f"objective = {objective!r}: must be a table")
    extra = ("front", "weights") if stiffness else ()
    _keys(objective, "objective", required=(), optional=("state", "tolerance", *extra))
    state = _string(objective, "objective", "state", "all_inverted")
    if state != "all_inverted":
        if (
            len(fields["n_units"]) != 1
            or len(state) != fields["n_units"][0]
            or set(state) - {"0", "1"}
        ):
            raise SceneSpecError(
                f"objective.state = {state!r}: 'all_inverted', or a bit string of N characters "
                "when variables.n_units is one number"
            )
    out: dict[str, Any] = {
        "targets": tuple(targets),
        "state": state,
        "tolerance": _positive(objective, "objective", "tolerance", 1e-6),
    }
    if stiffness:
        front = objective.get("front", [0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0])
        front = _numbers(front, "objective.front", length=None, unit="mm")
        if not front or any(v <= 0 for v in front):
            raise SceneSpecError(f"objective.front = {front!r}: need tolerances > 0 mm")
        out["front"] = tuple(sorted(front))
        if "weights" in objective:
            w = _numbers(objective["weights"], "objective.weights", length=2, unit="")
            if any(v < 0 for v in w) or not any(v > 0 for v in w):
                raise SceneSpecError(f"objective.weights = {list(w)!r}: need w >= 0, not both 0")
            out["weights"] = (w[0], w[1])
    return out


def parse_gripper(data: Mapping[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """The fields of a gripper scene: its ``[gripper]`` table."""
    for key in ("targets", "objective"):
        if key in data:
            raise SceneSpecError(f"{key}: not used by kind 'gripper' (its targets are [gripper])")
    if "gripper" not in data:
        raise SceneSpecError("gripper: missing [gripper] table")
    g = _table(data, "gripper")
    _keys(
        g,
        "gripper",
        required=("states", "apertures"),
        optional=(
            "aperture_tol",
            "activated",
            "theta_B_deg",
            "base_L",
            "min_window_kPa",
            "metastable_unit",
            "min_reset_s",
            "pulse",
            "reference",
        ),
    )
    if len(fields["n_units"]) != 1:
        raise SceneSpecError(
            f"variables.n_units = {list(fields['n_units'])}: the gripper needs one number of units"
        )
    n = fields["n_units"][0]
    states = g["states"]
    if (
        not isinstance(states, list)
        or not states
        or not all(isinstance(s, str) and len(s) == n and not set(s) - {"0", "1"} for s in states)
    ):
        raise SceneSpecError(f"gripper.states = {states!r}: need bit strings of {n} characters")
    apertures = _numbers(g["apertures"], "gripper.apertures", length=len(states), unit="mm")
    activated = _string(g, "gripper", "activated", states[-1])
    if len(activated) != n or set(activated) - {"0", "1"}:
        raise SceneSpecError(f"gripper.activated = {activated!r}: need {n} characters 0/1")
    unit = g.get("metastable_unit", n)
    if isinstance(unit, bool) or not isinstance(unit, int) or not 1 <= unit <= n:
        raise SceneSpecError(f"gripper.metastable_unit = {unit!r}: a unit in 1..{n}")
    pulse = g.get("pulse", {"P0": 0.7, "tau": [0.0, 0.5, 1.0, 1.1], "t_end": 2.0})
    if not isinstance(pulse, Mapping):
        raise SceneSpecError(f"gripper.pulse = {pulse!r}: must be a table")
    _keys(pulse, "gripper.pulse", required=("P0", "tau"), optional=("t_end",))
    tau = _numbers(pulse["tau"], "gripper.pulse.tau", length=4, unit="s")
    if any(b < a for a, b in pairwise(tau)) or tau[0] < 0:
        raise SceneSpecError(f"gripper.pulse.tau = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
    t_end = _positive(pulse, "gripper.pulse", "t_end", tau[3] + 1.0)
    pulse_P0 = _positive(pulse, "gripper.pulse", "P0", 0.7)
    try:  # the pressure range every entry point holds, checked before the optimisation
        PressureProfile.pulse(pulse_P0, tau)
    except ValueError as exc:
        raise SceneSpecError(f"gripper.pulse: {exc}") from None
    if t_end <= tau[3]:
        raise SceneSpecError(f"gripper.pulse.t_end = {t_end}: must be after τ4 = {tau[3]}")
    reference = theta_ref = base_ref = None
    if "reference" in g:
        reference, extra = _design(
            g["reference"], "gripper.reference", fields, extra=("theta_B_deg", "base_L")
        )
        theta_ref, base_ref = extra.get("theta_B_deg"), extra.get("base_L")
    spec = GripperSpec(
        states=tuple(states),
        apertures=tuple(apertures),
        aperture_tol=_positive(g, "gripper", "aperture_tol", 0.05),
        activated=activated,
        theta_B_deg=_range(
            g.get("theta_B_deg", {"min": -60.0, "max": 0.0}), "gripper.theta_B_deg", positive=False
        ),
        base_L=_range(g.get("base_L", {"min": 5.0, "max": 40.0}), "gripper.base_L"),
        min_window_kPa=_positive(g, "gripper", "min_window_kPa", 10.0, allow_zero=True),
        metastable_unit=unit,
        min_reset_s=_positive(g, "gripper", "min_reset_s", 0.05),
        pulse_P0=pulse_P0,
        pulse_tau=tuple(tau),
        pulse_t_end=t_end,
        reference=reference,
        reference_theta_B_deg=theta_ref,
        reference_base_L=base_ref,
    )
    return {"gripper": spec}


# ----------------------------------------------------------------------------- pieces


def _variables(table: Mapping[str, Any]) -> tuple[tuple[int, ...], dict[str, Any]]:
    _keys(
        table,
        "variables",
        required=("n_units", "H", "U_L", "U_sep", "t", "t_lim"),
        optional=("heights", "ordered_units", "tied", "shared_U_L", "shared_U_sep", "min_step"),
    )
    n_units = _n_units(table["n_units"])
    out: dict[str, Any] = {}
    H = table["H"]
    if isinstance(H, list):
        if len(n_units) != 1 or len(H) != n_units[0]:
            raise SceneSpecError(
                f"variables.H = {H!r}: one entry per unit needs one N (variables.n_units) and "
                f"{n_units[0] if len(n_units) == 1 else 'N'} entries"
            )
        out["H"] = [_bound(v, f"variables.H[{k}]") for k, v in enumerate(H)]
    else:
        out["H"] = _bound(H, "variables.H")
    for name in ("U_L", "U_sep", "t", "t_lim"):
        out[name] = _bound(table[name], f"variables.{name}")
    heights = table.get("heights", "free")
    if heights not in HEIGHT_ORDERS:
        raise SceneSpecError(
            f"variables.heights = {heights!r}: must be one of {', '.join(HEIGHT_ORDERS)}"
        )
    out["heights"] = heights
    if "ordered_units" in table:
        units = table["ordered_units"]
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
    if "tied" in table:
        tied = table["tied"]
        if not isinstance(tied, list) or not all(
            isinstance(g, list) and all(isinstance(u, int) and not isinstance(u, bool) for u in g)
            for g in tied
        ):
            raise SceneSpecError(f"variables.tied = {tied!r}: need lists of unit numbers")
        out["tied"] = tuple(tuple(g) for g in tied)
    if "min_step" in table:
        step = table["min_step"]
        if (
            isinstance(step, bool)
            or not isinstance(step, (int, float))
            or not math.isfinite(step)
            or step < 0
        ):
            raise SceneSpecError(f"variables.min_step = {step!r}: must be a number >= 0 mm")
        out["min_step"] = float(step)
    for name in ("shared_U_L", "shared_U_sep"):
        value = table.get(name, True)
        if not isinstance(value, bool):
            raise SceneSpecError(f"variables.{name} = {value!r}: must be true or false")
        out[name] = value
    return n_units, out


def _n_units(value: Any) -> tuple[int, ...]:
    where = "variables.n_units"

    def unit(v: Any) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_UNITS:
            raise SceneSpecError(f"{where} = {value!r}: need integers between 1 and {MAX_UNITS}")
        return v

    if isinstance(value, Mapping):
        _keys(value, where, required=("min", "max"), optional=())
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
    return _positive(scene, "scene", "E", 26.0), _poisson(scene, 0.35), ""


def _poisson(scene: Mapping[str, Any], default: float) -> float:
    nu = _positive(scene, "scene", "nu", default, allow_zero=True)
    if not nu < 0.5:
        raise SceneSpecError(f"scene.nu = {nu!r}: a Poisson ratio must be in [0, 0.5)")
    return nu


def _design(value: Any, where: str, fields: dict[str, Any], *, extra: tuple[str, ...]):
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table of design keys")
    data = {k: v for k, v in value.items() if k not in extra}
    data.setdefault("E", fields["E"])
    data.setdefault("nu", fields["nu"])
    if "constants" in data:
        raise SceneSpecError(
            f"{where}.constants: the scene's constants set applies (scene.constants)"
        )
    data["constants"] = fields["constants"]
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
    _keys(
        value,
        "optimiser",
        required=(),
        optional=("candidates_per_n", "starts_per_n", "max_iter", "seeds", "seeds_per_n"),
    )
    out: dict[str, Any] = {}
    if "seeds" in value:
        out["seeds"] = check_seeds(value["seeds"], "optimiser.seeds")
    for key, (low, high) in (
        ("candidates_per_n", (2, 1 << 20)),
        ("starts_per_n", (1, 1000)),
        ("max_iter", (1, 10000)),
        ("seeds_per_n", (1, 10000)),
    ):
        if key in value:
            v = value[key]
            if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
                raise SceneSpecError(f"optimiser.{key} = {v!r}: an integer in [{low}, {high}]")
            out[key] = v
    return OptimiserSettings(**out)


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


def with_seeds(spec: SceneSpec, dataset: str) -> SceneSpec:
    """The scene with its candidates seeded from ``dataset`` (``dpfexplore design --seeds``)."""
    if spec.kind not in ("position", "position_stiffness"):
        raise SceneSpecError(f"--seeds: only position scenes take seeds, not {spec.kind!r}")
    settings = replace(spec.optimiser, seeds=check_seeds(dataset, "--seeds"))
    return replace(spec, optimiser=settings)
