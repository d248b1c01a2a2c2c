"""Scene files of the timing scenes: pick-and-place reset times and the walker leg's zones.

Registers the kinds ``pickplace`` and ``walker_leg`` in :data:`.scene_jobs.SCENE_KINDS` (the
common tables ``[scene]``, ``[variables]``, ``[optimiser]`` are those of
:mod:`dpfexplore.inverse.spec`). As there, every problem is one :class:`SceneSpecError`
whose one-line message starts with the dotted key. Times in s, pressures in MPa, lengths in mm.

Pick-and-place (MODEL.md §9, paper eq. opti_pick_and_place)::

    [scene]
    kind = "pickplace"
    [variables]                    # one N; one free height (a tie group) and t free
    n_units = 6
    H = [4.0, 4.5, 5.0, 5.0, {min = 2.0, max = 4.0}, {min = 2.0, max = 4.0}]
    tied = [[5, 6]]
    U_L = 6.0
    U_sep = 1.0
    t = {min = 0.5, max = 1.0}
    t_lim = 1.0

    [pickplace]
    profile = {P0 = 0.7, tau = [0.0, 1.0, 5.0, 5.1], t_end = 15.0}   # the scene's pulse
    hold_units = [1, 2, 3, 4]      # must stay inverted (bistable): the grasp set point
    reset_unit = "last"            # "last": when every other inverted unit has reset (the
                                   # object is released); or a unit number
    targets = [0.3, 1.0, 2.0, 3.0] # target reset times (s); --target-reset T replaces them
    tolerance = 0.01               # relative: met when |reset - target| <= 1 % of target
    grasp_state = "111100"         # whose tip stiffness is reported and maximised
                                   # (default: the hold units inverted)
    screening = "fast"             # "fast" (where its trained scene matches), "release", "rodas4"
    grid = {t = 11, H = 41}        # screening lines of t, points of H per line
    search_atol = 1e-6             # mm: full model inside the root finding
    verify_atol = 1e-7             # mm: full model of every reported design
    prefer_fitted = true           # answer inside the fitted range when a bracket lies there

    [[pickplace.unit_targets]]     # optional: reset times of named units at once
    units = [5, 6]
    reset = [2.657, 1.613]

    [pickplace.difference]         # optional: the paper's form, max RT_2 - RT_1 and stiffness
    profile = {P0 = 1.0, tau = [0.0, 1.0, 5.0, 5.1], t_end = 15.0}   # profile 2
    max_reset = 6.0                # every reset under both profiles within this (s)
    weights = [1.0, 1.0]           # optional: w1 (1/K)^2 + w2 / (RT_2 - RT_1) as the paper

Walker leg (MODEL.md §10)::

    [scene]
    kind = "walker_leg"
    material = "cheetah-95a"
    [walker]
    leg = "walker-leg"             # base leg (example name or leg file): sections purple, green,
                                   # action, composition, fixed design keys
    monostable_leg = "walker-leg"  # the comparison leg, run at the scene's gait
    legs = ["front", "middle"]
    [walker.gait]
    walk_pressure = 0.2            # both phases while walking
    turn_pressure = 0.35           # phase 2 raised for one cycle: front legs turn
    phase1 = [0.0, 0.1, 1.1, 1.2]  # tau of phase 1 (purple zone)
    phase2 = [1.1, 1.2, 2.2, 2.3]  # tau of phase 2 (green zone and action section)
    period = 3.0                   # phase 1 repeats after this
    t_end = 5.0                    # tip path of one cycle
    cycles = 2                     # cycles in the timing diagram
    [walker.variables]             # per section: H (one bound for all its free units) and t
    purple = {H = {min = 1.8, max = 3.2}, t = {min = 0.55, max = 0.7}}
    green = {H = {min = 1.4, max = 2.6}, t = 1.0}
    action = {H = {min = 2.5, max = 4.2}, t = {min = 0.9, max = 1.0}}   # the action unit only
    [walker.requirements]
    pressure_margin_kPa = 10.0
    purple_reset = [1.0, 1.8]      # s after phase 1 ends: lifted through phase 2's hold, down
                                   # before phase 1 rises again
    purple_aim = [1.25, 1.55]      # root-finding aims of units 1 and 2 (inside the window)
    green_class = "monostable"
    front_action_min_reset = 3.0   # s after the raised phase 2 ends: a full gait cycle
    front_action_aim = 3.6
    middle_action_max_reset = 0.05 # monostable
    min_stride_ratio = 1.5         # over the monostable leg at the same gait
    [walker.search]
    t_lines = 4                    # values of t tried per section
    atol = 1e-5                    # mm: full model inside the root finding
    verify_atol = 1e-7             # mm: full model of every reported design
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from itertools import pairwise
from pathlib import Path
from typing import Any

from ...model.pressure import PressureProfile
from ...solvers.legs.leg import Leg, load_leg
from ...sweep.variables import DesignVariables
from ..spec_fields import (
    SceneSpecError,
    _keys,
    _numbers,
    _positive,
    _range,
    _string,
    _table,
)

__all__ = [
    "DifferenceSpec",
    "GaitSpec",
    "PickPlaceSpec",
    "PulseSpec",
    "UnitTarget",
    "WalkerRequirements",
    "WalkerSpec",
    "parse_pickplace",
    "parse_walker",
    "with_target_reset",
]

SCREENING = ("fast", "release", "rodas4")
LEG_ROLES = ("purple", "green", "action")
LEG_KINDS = ("front", "middle")


@dataclass(frozen=True)
class PulseSpec:
    """A pressure pulse and the horizon of its runs."""

    P0: float
    tau: tuple[float, float, float, float]
    t_end: float

    @property
    def profile(self) -> PressureProfile:
        """The :class:`PressureProfile`."""
        return PressureProfile.pulse(self.P0, self.tau)

    @property
    def horizon(self) -> float:
        """Time simulated after the release, s."""
        return self.t_end - self.tau[3]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"P0": self.P0, "tau": list(self.tau), "t_end": self.t_end}


@dataclass(frozen=True)
class UnitTarget:
    """Reset times of named units (1-based) at once."""

    units: tuple[int, ...]
    reset: tuple[float, ...]


@dataclass(frozen=True)
class DifferenceSpec:
    """The paper's two-profile objective: maximise ``RT_2 - RT_1`` (and the grasp stiffness)."""

    pulse: PulseSpec
    max_reset: float
    weights: tuple[float, float] | None = None


@dataclass(frozen=True)
class PickPlaceSpec:
    """The pick-and-place scene's requirements (module docstring)."""

    pulse: PulseSpec
    hold_units: tuple[int, ...]
    reset_unit: str | int
    targets: tuple[float, ...]
    unit_targets: tuple[UnitTarget, ...]
    tolerance: float
    grasp_state: str
    screening: str
    grid_t: int
    grid_H: int
    search_atol: float
    verify_atol: float
    prefer_fitted: bool
    difference: DifferenceSpec | None = None

    @property
    def n_results(self) -> int:
        """Result rows: one per target, per unit target, and the difference front."""
        return len(self.targets) + len(self.unit_targets) + (self.difference is not None)


@dataclass(frozen=True)
class GaitSpec:
    """A two-phase gait: phase 1 drives the purple zone, phase 2 the green zone and action."""

    walk_pressure: float
    turn_pressure: float
    phase1: tuple[float, float, float, float]
    phase2: tuple[float, float, float, float]
    period: float
    t_end: float
    cycles: int

    def phase(
        self,
        number: int,
        *,
        pressure: float | None = None,
        cycles: int = 1,
        raised_first: bool = False,
    ) -> PressureProfile:
        """Profile of phase ``number`` (1 or 2) over ``cycles`` cycles.

        ``pressure`` defaults to the walking pressure; ``raised_first`` runs the first cycle at
        the turning pressure (the turning command) and the others at ``pressure``.
        """
        tau = self.phase1 if number == 1 else self.phase2
        base = self.walk_pressure if pressure is None else pressure
        pulses = []
        for c in range(cycles):
            P0 = self.turn_pressure if raised_first and c == 0 else base
            pulses.append((P0, *(v + c * self.period for v in tau)))
        return PressureProfile.pulses(pulses)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "walk_pressure": self.walk_pressure,
            "turn_pressure": self.turn_pressure,
            "phase1": list(self.phase1),
            "phase2": list(self.phase2),
            "period": self.period,
            "t_end": self.t_end,
            "cycles": self.cycles,
        }


@dataclass(frozen=True)
class WalkerRequirements:
    """What each zone must do (the scene file states them; module docstring)."""

    pressure_margin_kPa: float = 10.0
    purple_reset: tuple[float, float] = (1.0, 1.8)
    purple_aim: tuple[float, float] = (1.25, 1.55)
    green_class: str = "monostable"
    front_action_min_reset: float = 3.0
    front_action_aim: float = 3.6
    middle_action_max_reset: float = 0.05
    min_stride_ratio: float = 1.5

    @property
    def margin(self) -> float:
        """Pressure margin, MPa."""
        return self.pressure_margin_kPa / 1000.0


@dataclass(frozen=True)
class WalkerSpec:
    """The walker-leg scene (module docstring)."""

    leg: Leg
    leg_source: str
    monostable_leg: Leg
    monostable_source: str
    legs: tuple[str, ...]
    gait: GaitSpec
    variables: dict[str, DesignVariables]
    requirements: WalkerRequirements
    t_lines: int = 4
    atol: float = 1e-5
    verify_atol: float = 1e-7
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def n_results(self) -> int:
        """One result row per designed leg."""
        return len(self.legs)


# ----------------------------------------------------------------------------- pick-and-place


def _pulse(value: Any, where: str, default: dict[str, Any]) -> PulseSpec:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table {{P0, tau, t_end}}")
    _keys(value, where, required=(), optional=("P0", "tau", "t_end"))
    merged = {**default, **value}
    P0 = _positive(merged, where, "P0", default.get("P0", 0.7))
    tau = _numbers(merged.get("tau"), f"{where}.tau", length=4, unit="s")
    if tau[0] < 0 or any(b < a for a, b in pairwise(tau)):
        raise SceneSpecError(f"{where}.tau = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
    t_end = _positive(merged, where, "t_end", tau[3] + 10.0)
    if t_end <= tau[3]:
        raise SceneSpecError(f"{where}.t_end = {t_end}: must be after τ4 = {tau[3]}")
    try:
        PressureProfile.pulse(P0, tau)
    except ValueError as exc:
        raise SceneSpecError(f"{where}: {exc}") from None
    return PulseSpec(P0, (tau[0], tau[1], tau[2], tau[3]), t_end)


def _units(value: Any, where: str, n: int) -> tuple[int, ...]:
    if (
        not isinstance(value, list)
        or not all(isinstance(u, int) and not isinstance(u, bool) and 1 <= u <= n for u in value)
        or len(set(value)) != len(value)
    ):
        raise SceneSpecError(f"{where} = {value!r}: need distinct unit numbers in 1..{n}")
    return tuple(value)


def _integer(
    table: Mapping[str, Any], where: str, key: str, default: int, low: int, high: int
) -> int:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise SceneSpecError(f"{where}.{key} = {value!r}: an integer in [{low}, {high}]")
    return value


def _bool(table: Mapping[str, Any], where: str, key: str, default: bool) -> bool:
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise SceneSpecError(f"{where}.{key} = {value!r}: must be true or false")
    return value


_PULSE = {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0}


def parse_pickplace(data: Mapping[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """The ``[pickplace]`` table (module docstring) -> ``{"pickplace": PickPlaceSpec}``."""
    if "pickplace" not in data:
        raise SceneSpecError("pickplace: missing [pickplace] table")
    p = _table(data, "pickplace")
    _keys(
        p,
        "pickplace",
        required=(),
        optional=(
            "profile",
            "hold_units",
            "reset_unit",
            "targets",
            "unit_targets",
            "tolerance",
            "grasp_state",
            "screening",
            "grid",
            "search_atol",
            "verify_atol",
            "prefer_fitted",
            "difference",
        ),
    )
    if len(fields["n_units"]) != 1:
        raise SceneSpecError(
            f"variables.n_units = {list(fields['n_units'])}: the pick-and-place "
            "scene needs one number of units"
        )
    n = fields["n_units"][0]
    variables = DesignVariables(n_units=n, E=fields["E"], nu=fields["nu"], **fields["variables"])
    names = variables.names
    if len(names) != 2 or not names[0].startswith("H_") or names[1] != "t":
        raise SceneSpecError(
            f"variables: free {list(names)}; the pick-and-place scene needs exactly one free "
            "height (a unit or a tied group, e.g. tied = [[5, 6]]) and t"
        )
    pulse = _pulse(p.get("profile", {}), "pickplace.profile", _PULSE)
    hold = _units(p.get("hold_units", list(range(1, n - 1))), "pickplace.hold_units", n)
    reset_unit = p.get("reset_unit", "last")
    if reset_unit != "last" and (
        isinstance(reset_unit, bool)
        or not isinstance(reset_unit, int)
        or not 1 <= reset_unit <= n
        or reset_unit in hold
    ):
        raise SceneSpecError(
            f"pickplace.reset_unit = {reset_unit!r}: 'last' or a unit in 1..{n} "
            "that is not a hold unit"
        )
    targets = _numbers(p.get("targets", [1.0]), "pickplace.targets", length=None, unit="s")
    for v in targets:
        if not 0 < v < pulse.horizon:
            raise SceneSpecError(
                f"pickplace.targets = {list(targets)}: each target must be in "
                f"(0, {pulse.horizon:g}) s (the horizon after the release)"
            )
    unit_targets = []
    raw = p.get("unit_targets", [])
    if not isinstance(raw, list) or not all(isinstance(e, Mapping) for e in raw):
        raise SceneSpecError("pickplace.unit_targets: need [[pickplace.unit_targets]] tables")
    for i, entry in enumerate(raw):
        where = f"pickplace.unit_targets[{i}]"
        _keys(entry, where, required=("units", "reset"), optional=())
        units = _units(entry["units"], f"{where}.units", n)
        if len(units) != 2 or set(units) & set(hold):
            raise SceneSpecError(
                f"{where}.units = {list(units)}: two units that are not hold "
                "units (two reset times fix the two variables)"
            )
        reset = _numbers(entry["reset"], f"{where}.reset", length=len(units), unit="s")
        if any(not 0 < v < pulse.horizon for v in reset):
            raise SceneSpecError(f"{where}.reset = {list(reset)}: each in (0, {pulse.horizon:g}) s")
        unit_targets.append(UnitTarget(units, reset))
    if not targets and not unit_targets and "difference" not in p:
        raise SceneSpecError(
            "pickplace.targets = []: give a target, a unit target or a difference objective"
        )
    grasp = _string(
        p, "pickplace", "grasp_state", "".join("1" if k + 1 in hold else "0" for k in range(n))
    )
    if len(grasp) != n or set(grasp) - {"0", "1"}:
        raise SceneSpecError(f"pickplace.grasp_state = {grasp!r}: need {n} characters 0/1")
    screening = _string(p, "pickplace", "screening", "fast")
    if screening not in SCREENING:
        raise SceneSpecError(f"pickplace.screening = {screening!r}: one of {', '.join(SCREENING)}")
    grid = p.get("grid", {})
    if not isinstance(grid, Mapping):
        raise SceneSpecError(f"pickplace.grid = {grid!r}: must be a table {{t, H}}")
    _keys(grid, "pickplace.grid", required=(), optional=("t", "H"))
    difference = None
    if "difference" in p:
        d = p["difference"]
        if not isinstance(d, Mapping):
            raise SceneSpecError(f"pickplace.difference = {d!r}: must be a table")
        _keys(d, "pickplace.difference", required=("profile",), optional=("max_reset", "weights"))
        second = _pulse(
            d["profile"],
            "pickplace.difference.profile",
            {**_PULSE, "tau": list(pulse.tau), "t_end": pulse.t_end},
        )
        max_reset = _positive(
            d, "pickplace.difference", "max_reset", min(pulse.horizon, second.horizon) / 2
        )
        if max_reset >= min(pulse.horizon, second.horizon):
            raise SceneSpecError(
                f"pickplace.difference.max_reset = {max_reset}: must be below "
                "both profiles' horizons"
            )
        weights = None
        if "weights" in d:
            w = _numbers(d["weights"], "pickplace.difference.weights", length=2, unit="")
            if any(v < 0 for v in w) or not any(v > 0 for v in w):
                raise SceneSpecError(
                    f"pickplace.difference.weights = {list(w)}: need w >= 0, not both 0"
                )
            weights = (w[0], w[1])
        difference = DifferenceSpec(second, max_reset, weights)
    spec = PickPlaceSpec(
        pulse=pulse,
        hold_units=hold,
        reset_unit=reset_unit,
        targets=tuple(targets),
        unit_targets=tuple(unit_targets),
        tolerance=_positive(p, "pickplace", "tolerance", 0.01),
        grasp_state=grasp,
        screening=screening,
        grid_t=_integer(grid, "pickplace.grid", "t", 11, 2, 1000),
        grid_H=_integer(grid, "pickplace.grid", "H", 41, 3, 10000),
        search_atol=_positive(p, "pickplace", "search_atol", 1e-6),
        verify_atol=_positive(p, "pickplace", "verify_atol", 1e-7),
        prefer_fitted=_bool(p, "pickplace", "prefer_fitted", True),
        difference=difference,
    )
    return {"pickplace": spec}


def with_target_reset(spec, target: float):
    """The scene with its targets replaced by one target reset time ``target`` (s).

    ``--target-reset T`` of ``dpfexplore design``: the unit targets and the difference objective
    are dropped too (the command asks for one reset time). ``ValueError`` naming the option for a
    scene of another kind or a target outside the horizon.
    """
    if spec.kind != "pickplace":
        raise ValueError(
            f"--target-reset {target}: only for pick-and-place scenes (scene.kind = {spec.kind!r})"
        )
    p = spec.pickplace
    if not (math.isfinite(target) and 0 < target < p.pulse.horizon):
        raise ValueError(
            f"--target-reset {target}: must be in (0, {p.pulse.horizon:g}) s "
            "(the horizon after the release)"
        )
    return replace(
        spec, pickplace=replace(p, targets=(float(target),), unit_targets=(), difference=None)
    )


# ----------------------------------------------------------------------------- walker


def _leg(value: Any, where: str) -> tuple[Leg, str]:
    from ...examples import NAMES, example_path

    if not isinstance(value, str) or not value:
        raise SceneSpecError(
            f"{where} = {value!r}: an example name ({', '.join(NAMES)}) or a leg file"
        )
    path = example_path(value) if value in NAMES else Path(value)
    if not path.is_file():
        raise SceneSpecError(f"{where} = {value!r}: no such leg file or example")
    try:
        leg = load_leg(path)
    except (OSError, ValueError) as exc:
        raise SceneSpecError(f"{where} = {value!r}: {exc}") from None
    names = tuple(s.name for s in leg.sections)
    if names != LEG_ROLES or leg.composition != "dpw":
        raise SceneSpecError(
            f"{where} = {value!r}: need the walker's three sections "
            f"{', '.join(LEG_ROLES)} (composition 'dpw'), got {list(names)}"
        )
    return leg, value


def _section_variables(value: Any, where: str, design, role: str) -> DesignVariables:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table {{H, t}}")
    _keys(value, where, required=("H",), optional=("t",))

    def bound(v: Any, key: str):
        if isinstance(v, Mapping):
            return _range(v, key)
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not (math.isfinite(v) and v > 0)
        ):
            raise SceneSpecError(f"{key} = {v!r}: give a number or {{min, max}}")
        return float(v)

    H = bound(value["H"], f"{where}.H")
    t = bound(value.get("t", design.t), f"{where}.t")
    n = design.n_units
    heights = [H, *design.H[1:]] if role == "action" else [H] * n
    try:
        return DesignVariables(
            n_units=n,
            H=heights,
            U_L=design.U_L[0],
            U_sep=design.U_sep[0],
            t=t,
            t_lim=design.t_lim,
            E=design.E,
            nu=design.nu,
            r_b=design.r_b,
            t_ch=design.t_ch,
        )
    except ValueError as exc:
        raise SceneSpecError(f"{where}: {exc}") from None


def parse_walker(data: Mapping[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """The ``[walker]`` table (module docstring) -> ``{"walker": WalkerSpec, "n_units": ...}``."""
    if "walker" not in data:
        raise SceneSpecError("walker: missing [walker] table")
    w = _table(data, "walker")
    _keys(
        w,
        "walker",
        required=("gait", "variables"),
        optional=("leg", "monostable_leg", "legs", "requirements", "search"),
    )
    leg, source = _leg(w.get("leg", "walker-leg"), "walker.leg")
    mono, mono_source = _leg(w.get("monostable_leg", "walker-leg"), "walker.monostable_leg")
    # The scene's material: every section of both legs.
    sections = tuple(
        replace(s, design=s.design.replace(E=fields["E"], nu=fields["nu"])) for s in leg.sections
    )
    leg = replace(leg, sections=sections)
    mono = replace(
        mono,
        sections=tuple(
            replace(s, design=s.design.replace(E=fields["E"], nu=fields["nu"]))
            for s in mono.sections
        ),
    )
    legs = w.get("legs", list(LEG_KINDS))
    if (
        not isinstance(legs, list)
        or not legs
        or any(k not in LEG_KINDS for k in legs)
        or len(set(legs)) != len(legs)
    ):
        raise SceneSpecError(f"walker.legs = {legs!r}: distinct entries of {', '.join(LEG_KINDS)}")
    g = _table(w, "gait")
    where = "walker.gait"
    _keys(
        g,
        where,
        required=("walk_pressure", "phase1", "phase2", "period"),
        optional=("turn_pressure", "t_end", "cycles"),
    )
    walk = _positive(g, where, "walk_pressure", 0.2)
    turn = _positive(g, where, "turn_pressure", walk)
    if "front" in legs and turn <= walk:
        raise SceneSpecError(
            f"{where}.turn_pressure = {turn}: must be above walk_pressure = "
            f"{walk} for a front leg (raising a phase turns the walker)"
        )
    phases = []
    for key in ("phase1", "phase2"):
        tau = _numbers(g[key], f"{where}.{key}", length=4, unit="s")
        if tau[0] < 0 or any(b < a for a, b in pairwise(tau)):
            raise SceneSpecError(f"{where}.{key} = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
        phases.append((tau[0], tau[1], tau[2], tau[3]))
    period = _positive(g, where, "period", 3.0)
    if period < max(phases[0][3], phases[1][3]) - min(phases[0][0], phases[1][0]):
        raise SceneSpecError(f"{where}.period = {period}: shorter than one cycle of both phases")
    t_end = _positive(g, where, "t_end", max(phases[0][3], phases[1][3]) + 2.0)
    if t_end < max(phases[0][3], phases[1][3]):
        raise SceneSpecError(f"{where}.t_end = {t_end}: before the phases end")
    cycles = _integer(g, where, "cycles", 2, 1, 20)
    gait = GaitSpec(walk, turn, phases[0], phases[1], period, t_end, cycles)
    try:
        for number in (1, 2):
            gait.phase(number, cycles=cycles, raised_first=True)
    except ValueError as exc:
        raise SceneSpecError(f"{where}: {exc}") from None
    v = _table(w, "variables")
    _keys(v, "walker.variables", required=LEG_ROLES, optional=())
    variables = {
        role: _section_variables(
            v[role], f"walker.variables.{role}", leg.section(role).design, role
        )
        for role in LEG_ROLES
    }
    requirements = _requirements(w.get("requirements", {}), gait)
    search = w.get("search", {})
    if not isinstance(search, Mapping):
        raise SceneSpecError(f"walker.search = {search!r}: must be a table")
    _keys(search, "walker.search", required=(), optional=("t_lines", "atol", "verify_atol"))
    spec = WalkerSpec(
        leg=leg,
        leg_source=source,
        monostable_leg=mono,
        monostable_source=mono_source,
        legs=tuple(legs),
        gait=gait,
        variables=variables,
        requirements=requirements,
        t_lines=_integer(search, "walker.search", "t_lines", 4, 1, 100),
        atol=_positive(search, "walker.search", "atol", 1e-5),
        verify_atol=_positive(search, "walker.search", "verify_atol", 1e-7),
    )
    n_max = max(s.design.n_units for s in leg.sections)
    return {"walker": spec, "n_units": (n_max,)}


def _requirements(value: Any, gait: GaitSpec) -> WalkerRequirements:
    where = "walker.requirements"
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table")
    names = WalkerRequirements.__dataclass_fields__
    _keys(value, where, required=(), optional=tuple(names))
    base = WalkerRequirements(
        front_action_min_reset=gait.period, front_action_aim=1.2 * gait.period
    )
    out: dict[str, Any] = {}
    for key in (
        "pressure_margin_kPa",
        "front_action_min_reset",
        "front_action_aim",
        "middle_action_max_reset",
        "min_stride_ratio",
    ):
        out[key] = _positive(value, where, key, getattr(base, key), allow_zero=True)
    for key in ("purple_reset", "purple_aim"):
        pair = _numbers(
            value.get(key, list(getattr(base, key))), f"{where}.{key}", length=2, unit="s"
        )
        if any(v <= 0 for v in pair):
            raise SceneSpecError(f"{where}.{key} = {list(pair)}: need times > 0 s")
        out[key] = (pair[0], pair[1])
    low, high = out["purple_reset"]
    if low > high:
        raise SceneSpecError(f"{where}.purple_reset = {[low, high]}: min above max")
    if not all(low <= a <= high for a in out["purple_aim"]):
        raise SceneSpecError(
            f"{where}.purple_aim = {list(out['purple_aim'])}: must lie in "
            f"purple_reset = {[low, high]}"
        )
    if out["front_action_aim"] < out["front_action_min_reset"]:
        raise SceneSpecError(
            f"{where}.front_action_aim = {out['front_action_aim']}: below "
            f"front_action_min_reset = {out['front_action_min_reset']}"
        )
    green = _string(value, where, "green_class", base.green_class)
    if green not in ("monostable", "metastable", "any"):
        raise SceneSpecError(f"{where}.green_class = {green!r}: monostable, metastable or any")
    out["green_class"] = green
    return WalkerRequirements(**out)
