"""What a scene is: its targets, design variables, material, objective and budget, as records.

:class:`SceneSpec` holds a validated scene of any kind: the parts every kind shares (name, seed,
material, the numbers of units and the :class:`~dpfexplore.sweep.variables.DesignVariables` fields
per ``N``, the :class:`OptimiserSettings` and the constants set) and the kind's own: the
:class:`Target` points of the position kinds, the :class:`GripperSpec`, or the timing scenes'
specs (:mod:`dpfexplore.inverse.scenes.timing_spec`). Scene files are read into these records by
:mod:`dpfexplore.inverse.scene_file` (the format is in its docstring).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.design import Design
from ..model.variables import DesignVariables
from .scenes.timing_spec import PickPlaceSpec, WalkerSpec

__all__ = ["GripperSpec", "OptimiserSettings", "SceneSpec", "Target"]


@dataclass(frozen=True)
class Target:
    """One target of a position scene.

    Attributes
    ----------
    point : tuple of float
        Tip ``(x, y)`` of the targeted state, mm (model frame).
    reference : Design or None
        A design to compare with (e.g. the paper's), with the scene's material.
    """

    point: tuple[float, float]
    reference: Design | None = None


@dataclass(frozen=True)
class OptimiserSettings:
    """Budget of the optimiser (see :mod:`dpfexplore.inverse.engine.optimiser`)."""

    candidates_per_n: int = 64
    starts_per_n: int = 3
    max_iter: int = 60
    #: Sweep dataset whose nearest designs seed the position kinds (None: a Latin hypercube).
    seeds: str | None = None
    seeds_per_n: int = 8


@dataclass(frozen=True)
class GripperSpec:
    """The multi-aperture gripper's targets and requirements (MODEL.md §7, §9)."""

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


@dataclass(frozen=True)
class SceneSpec:
    """A validated scene (the file's keys are in :mod:`~.scene_file`).

    Attributes
    ----------
    kind, name, description : str
    seed : int
    E, nu : float
        Material (MPa, 1).
    material : str
        Preset key, or ``""`` when ``E`` was given.
    n_units : tuple of int
        The numbers of units searched.
    variables : dict
        :class:`DesignVariables` fields other than ``n_units``, ``E`` and ``nu``.
    targets : tuple of Target
        Position kinds; empty for the gripper.
    state : str
        ``"all_inverted"`` or a bit string: the targeted state of the position kinds.
    tolerance : float, mm²
    front : tuple of float, mm
        Tip tolerances of the stiffness front (position_stiffness).
    weights : tuple of float or None
        ``(w1, w2)`` of the paper's weighted sum, if asked.
    optimiser : OptimiserSettings
    gripper : GripperSpec or None
    document : dict
        The parsed TOML, recorded with the results.
    constants : ConstantsSet
        The closed forms every design of the scene runs on (the paper's by default).
    """

    kind: str
    name: str
    description: str
    seed: int
    E: float
    nu: float
    material: str
    n_units: tuple[int, ...]
    variables: dict[str, Any]
    targets: tuple[Target, ...] = ()
    state: str = "all_inverted"
    tolerance: float = 1e-6
    front: tuple[float, ...] = ()
    weights: tuple[float, float] | None = None
    optimiser: OptimiserSettings = field(default_factory=OptimiserSettings)
    gripper: GripperSpec | None = None
    #: The ``pickplace`` and ``walker_leg`` kinds' own specs
    #: (:mod:`dpfexplore.inverse.scenes.timing_spec`); None for the other kinds.
    pickplace: PickPlaceSpec | None = None
    walker: WalkerSpec | None = None
    document: dict[str, Any] = field(default_factory=dict, compare=False)
    constants: ConstantsSet = DEFAULT

    def design_variables(self, n_units: int) -> DesignVariables:
        """The design variables of ``n_units``-unit designs."""
        return DesignVariables(
            n_units=n_units, E=self.E, nu=self.nu, constants=self.constants, **self.variables
        )
