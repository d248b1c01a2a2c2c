"""Scene file of the pick-and-place scene: the ``[pickplace]`` table (MODEL.md §9).

The tables every kind shares are read by :mod:`dpfexplore.inverse.scene_file`; as there, every
problem is one :class:`~dpfexplore.inverse.scene_file.SceneSpecError` whose one-line message
starts with the dotted key. Times in s, pressures in MPa (paper eq. opti_pick_and_place)::

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

``dpfexplore design --target-reset T`` (:func:`with_target_reset`) replaces the targets by ``T``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import Any

from ....io.toml_fields import (
    boolean,
    check_keys,
    integer_in,
    numbers,
    positive_number,
    string,
    table,
)
from ....model.pressure import PressureProfile
from ...scene_file import SceneSpecError
from ...spec import SceneCommon, SceneSpec

__all__ = [
    "SCREENING",
    "DifferenceSpec",
    "PickPlaceSpec",
    "PulseSpec",
    "UnitTarget",
    "parse_pickplace",
    "with_target_reset",
]

SCREENING = ("fast", "release", "rodas4")


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


def _pulse(value: Any, where: str, default: dict[str, Any]) -> PulseSpec:
    if not isinstance(value, Mapping):
        raise SceneSpecError(f"{where} = {value!r}: must be a table {{P0, tau, t_end}}")
    check_keys(value, where, required=(), optional=("P0", "tau", "t_end"))
    merged = {**default, **value}
    P0 = positive_number(merged, where, "P0", default.get("P0", 0.7))
    tau = numbers(merged.get("tau"), f"{where}.tau", length=4, unit="s")
    if tau[0] < 0 or any(b < a for a, b in pairwise(tau)):
        raise SceneSpecError(f"{where}.tau = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
    t_end = positive_number(merged, where, "t_end", tau[3] + 10.0)
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


_PULSE = {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0}


def parse_pickplace(data: Mapping[str, Any], common: SceneCommon) -> PickPlaceSpec:
    """The ``[pickplace]`` table (module docstring) -> :class:`PickPlaceSpec`."""
    if "pickplace" not in data:
        raise SceneSpecError("pickplace: missing [pickplace] table")
    p = table(data, "pickplace")
    check_keys(
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
    if len(common.n_units) != 1:
        raise SceneSpecError(
            f"variables.n_units = {list(common.n_units)}: the pick-and-place "
            "scene needs one number of units"
        )
    n = common.n_units[0]
    variables = common.design_variables(n)
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
    targets = numbers(p.get("targets", [1.0]), "pickplace.targets", length=None, unit="s")
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
        check_keys(entry, where, required=("units", "reset"), optional=())
        units = _units(entry["units"], f"{where}.units", n)
        if len(units) != 2 or set(units) & set(hold):
            raise SceneSpecError(
                f"{where}.units = {list(units)}: two units that are not hold "
                "units (two reset times fix the two variables)"
            )
        reset = numbers(entry["reset"], f"{where}.reset", length=len(units), unit="s")
        if any(not 0 < v < pulse.horizon for v in reset):
            raise SceneSpecError(f"{where}.reset = {list(reset)}: each in (0, {pulse.horizon:g}) s")
        unit_targets.append(UnitTarget(units, reset))
    if not targets and not unit_targets and "difference" not in p:
        raise SceneSpecError(
            "pickplace.targets = []: give a target, a unit target or a difference objective"
        )
    grasp = string(
        p,
        "pickplace",
        "grasp_state",
        default="".join("1" if k + 1 in hold else "0" for k in range(n)),
    )
    if len(grasp) != n or set(grasp) - {"0", "1"}:
        raise SceneSpecError(f"pickplace.grasp_state = {grasp!r}: need {n} characters 0/1")
    screening = string(p, "pickplace", "screening", default="fast")
    if screening not in SCREENING:
        raise SceneSpecError(f"pickplace.screening = {screening!r}: one of {', '.join(SCREENING)}")
    grid = p.get("grid", {})
    if not isinstance(grid, Mapping):
        raise SceneSpecError(f"pickplace.grid = {grid!r}: must be a table {{t, H}}")
    check_keys(grid, "pickplace.grid", required=(), optional=("t", "H"))
    difference = None
    if "difference" in p:
        d = p["difference"]
        if not isinstance(d, Mapping):
            raise SceneSpecError(f"pickplace.difference = {d!r}: must be a table")
        check_keys(
            d, "pickplace.difference", required=("profile",), optional=("max_reset", "weights")
        )
        second = _pulse(
            d["profile"],
            "pickplace.difference.profile",
            {**_PULSE, "tau": list(pulse.tau), "t_end": pulse.t_end},
        )
        max_reset = positive_number(
            d, "pickplace.difference", "max_reset", min(pulse.horizon, second.horizon) / 2
        )
        if max_reset >= min(pulse.horizon, second.horizon):
            raise SceneSpecError(
                f"pickplace.difference.max_reset = {max_reset}: must be below "
                "both profiles' horizons"
            )
        weights = None
        if "weights" in d:
            w = numbers(d["weights"], "pickplace.difference.weights", length=2, unit="")
            if any(v < 0 for v in w) or not any(v > 0 for v in w):
                raise SceneSpecError(
                    f"pickplace.difference.weights = {list(w)}: need w >= 0, not both 0"
                )
            weights = (w[0], w[1])
        difference = DifferenceSpec(second, max_reset, weights)
    return PickPlaceSpec(
        pulse=pulse,
        hold_units=hold,
        reset_unit=reset_unit,
        targets=tuple(targets),
        unit_targets=tuple(unit_targets),
        tolerance=positive_number(p, "pickplace", "tolerance", 0.01),
        grasp_state=grasp,
        screening=screening,
        grid_t=integer_in(grid, "pickplace.grid", "t", default=11, low=2, high=1000),
        grid_H=integer_in(grid, "pickplace.grid", "H", default=41, low=3, high=10000),
        search_atol=positive_number(p, "pickplace", "search_atol", 1e-6),
        verify_atol=positive_number(p, "pickplace", "verify_atol", 1e-7),
        prefer_fitted=boolean(p, "pickplace", "prefer_fitted", default=True),
        difference=difference,
    )


def with_target_reset(spec: SceneSpec, target: float) -> SceneSpec[PickPlaceSpec]:
    """The scene with its targets replaced by one target reset time ``target`` (s).

    ``--target-reset T`` of ``dpfexplore design``: the unit targets and the difference objective
    are dropped too (the command asks for one reset time). ``ValueError`` naming the option for a
    scene of another kind or a target outside the horizon.
    """
    if not isinstance(spec.kind_spec, PickPlaceSpec):
        raise ValueError(
            f"--target-reset {target}: only for pick-and-place scenes (scene.kind = {spec.kind!r})"
        )
    p = spec.kind_spec
    if not (math.isfinite(target) and 0 < target < p.pulse.horizon):
        raise ValueError(
            f"--target-reset {target}: must be in (0, {p.pulse.horizon:g}) s "
            "(the horizon after the release)"
        )
    return replace(
        spec, kind_spec=replace(p, targets=(float(target),), unit_targets=(), difference=None)
    )
