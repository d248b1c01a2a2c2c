"""Scene file of the multi-aperture gripper: its ``[gripper]`` table (MODEL.md §7, §9).

The tables every kind shares are read by :mod:`dpfexplore.inverse.scene_file`; as there, every
problem is one :class:`~dpfexplore.inverse.scene_file.SceneSpecError` whose one-line message
starts with the dotted key. Lengths in mm, pressures in MPa (``min_window_kPa`` in kPa), times
in s::

    [scene]
    kind = "gripper"

    [variables]                   # one number of units
    n_units = 5

    [gripper]
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

    [gripper.sorting]             # optional: the sorting objective (docs/guide/grasp.md)
    classes = [                   # diameter ranges must not overlap; masses >= 0
      {name = "large", diameter = {min = 67.0, max = 73.0}, mass = {min = 0.0, max = 0.001}},
      {name = "small", diameter = {min = 32.0, max = 38.0}, mass = 0.001},   # kg
    ]
    mu = 0.5                      # Coulomb friction at the contacts
    lift_s = 0.05                 # s; default min_reset_s: the tip unit used if it lasts
    diameter_scale_mm = 1.0       # the margin counts 1 mm of diameter ...
    mass_scale_kg = 0.001         # ... as 1 g of mass
    max_evaluations = 24          # loop margins the aperture search may evaluate
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import Any

from ....io.toml_fields import check_keys, interval, numbers, positive_number, string, table
from ....model.design import Design
from ....model.pressure import PressureProfile
from ...scene_file import SceneSpecError, reference_design
from ...spec import SceneCommon
from .sorting import SortingSpec, check_open_gripper, open_aperture, parse_sorting

__all__ = ["GripperSpec", "parse_gripper"]


@dataclass(frozen=True)
class GripperSpec:
    """The multi-aperture gripper's targets and requirements (module docstring).

    Attributes
    ----------
    states : tuple of str
        The grasp states (bit strings), in the order a rising pressure meets them.
    apertures : tuple of float
        Target aperture of each state, mm.
    aperture_tol : float
        mm.
    activated : str
        The state whose tip stiffness is maximised.
    theta_B_deg, base_L : (low, high)
        Bounds of the base angle (degrees) and length (mm).
    min_window_kPa : float
        Least pressure window of each state, kPa.
    metastable_unit : int
        The unit (1-based) that must reset under the pulse.
    min_reset_s : float
        Its least reset time, s.
    pulse_P0, pulse_tau, pulse_t_end : float, (τ1, τ2, τ3, τ4), float
        The pulse (MPa, s) and the end of its runs (s).
    reference, reference_theta_B_deg, reference_base_L : Design, float, float, or None
        A gripper to compare with (degrees, mm).
    sorting : SortingSpec or None
        The sorting objective (``[gripper.sorting]``), if any.
    """

    states: tuple[str, ...]
    apertures: tuple[float, ...]
    aperture_tol: float
    activated: str
    theta_B_deg: tuple[float, float]
    base_L: tuple[float, float]
    min_window_kPa: float
    metastable_unit: int
    min_reset_s: float
    pulse_P0: float
    pulse_tau: tuple[float, float, float, float]
    pulse_t_end: float
    reference: Design | None = None
    reference_theta_B_deg: float | None = None
    reference_base_L: float | None = None
    sorting: SortingSpec | None = None

    @property
    def n_results(self) -> int:
        """One result row: the set of apertures."""
        return 1


def parse_gripper(data: Mapping[str, Any], common: SceneCommon) -> GripperSpec:
    """The ``[gripper]`` table (module docstring) -> :class:`GripperSpec`."""
    for key in ("targets", "objective"):
        if key in data:
            raise SceneSpecError(f"{key}: not used by kind 'gripper' (its targets are [gripper])")
    if "gripper" not in data:
        raise SceneSpecError("gripper: missing [gripper] table")
    g = table(data, "gripper")
    check_keys(
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
            "sorting",
        ),
    )
    if len(common.n_units) != 1:
        raise SceneSpecError(
            f"variables.n_units = {list(common.n_units)}: the gripper needs one number of units"
        )
    n = common.n_units[0]
    states = g["states"]
    if (
        not isinstance(states, list)
        or not states
        or not all(isinstance(s, str) and len(s) == n and not set(s) - {"0", "1"} for s in states)
    ):
        raise SceneSpecError(f"gripper.states = {states!r}: need bit strings of {n} characters")
    apertures = numbers(g["apertures"], "gripper.apertures", length=len(states), unit="mm")
    activated = string(g, "gripper", "activated", default=states[-1])
    if len(activated) != n or set(activated) - {"0", "1"}:
        raise SceneSpecError(f"gripper.activated = {activated!r}: need {n} characters 0/1")
    unit = g.get("metastable_unit", n)
    if isinstance(unit, bool) or not isinstance(unit, int) or not 1 <= unit <= n:
        raise SceneSpecError(f"gripper.metastable_unit = {unit!r}: a unit in 1..{n}")
    pulse = g.get("pulse", {"P0": 0.7, "tau": [0.0, 0.5, 1.0, 1.1], "t_end": 2.0})
    if not isinstance(pulse, Mapping):
        raise SceneSpecError(f"gripper.pulse = {pulse!r}: must be a table")
    check_keys(pulse, "gripper.pulse", required=("P0", "tau"), optional=("t_end",))
    tau = numbers(pulse["tau"], "gripper.pulse.tau", length=4, unit="s")
    if any(b < a for a, b in pairwise(tau)) or tau[0] < 0:
        raise SceneSpecError(f"gripper.pulse.tau = {list(tau)}: need 0 <= τ1 <= τ2 <= τ3 <= τ4")
    t_end = positive_number(pulse, "gripper.pulse", "t_end", tau[3] + 1.0)
    pulse_P0 = positive_number(pulse, "gripper.pulse", "P0", 0.7)
    try:  # the pressure range every entry point holds, checked before the optimisation
        PressureProfile.pulse(pulse_P0, tau)
    except ValueError as exc:
        raise SceneSpecError(f"gripper.pulse: {exc}") from None
    if t_end <= tau[3]:
        raise SceneSpecError(f"gripper.pulse.t_end = {t_end}: must be after τ4 = {tau[3]}")
    reference = theta_ref = base_ref = None
    if "reference" in g:
        reference, extra = reference_design(
            g["reference"], "gripper.reference", common, extra=("theta_B_deg", "base_L")
        )
        theta_ref, base_ref = extra.get("theta_B_deg"), extra.get("base_L")
    spec = GripperSpec(
        states=tuple(states),
        apertures=tuple(apertures),
        aperture_tol=positive_number(g, "gripper", "aperture_tol", 0.05),
        activated=activated,
        theta_B_deg=interval(
            g.get("theta_B_deg", {"min": -60.0, "max": 0.0}), "gripper.theta_B_deg", positive=False
        ),
        base_L=interval(g.get("base_L", {"min": 5.0, "max": 40.0}), "gripper.base_L"),
        min_window_kPa=positive_number(g, "gripper", "min_window_kPa", 10.0, allow_zero=True),
        metastable_unit=unit,
        min_reset_s=positive_number(g, "gripper", "min_reset_s", 0.05),
        pulse_P0=pulse_P0,
        pulse_tau=tuple(tau),
        pulse_t_end=t_end,
        reference=reference,
        reference_theta_B_deg=theta_ref,
        reference_base_L=base_ref,
    )
    if "sorting" not in g:
        return spec
    sorting = parse_sorting(g["sorting"], spec.states, spec.metastable_unit, spec.min_reset_s)
    if reference is not None and theta_ref is not None and base_ref is not None:
        check_open_gripper(sorting, open_aperture(reference, base_ref, theta_ref), "the reference")
    return replace(spec, sorting=sorting)
