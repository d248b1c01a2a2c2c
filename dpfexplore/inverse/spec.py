"""What a scene is: the parts every kind shares, and the kind's own spec, as records.

:class:`SceneSpec` is a validated scene of any kind: what every kind shares (name, seed,
material, the numbers of units and the :class:`~dpfexplore.model.variables.DesignVariables`
fields per ``N``, the :class:`~.engine.settings.OptimiserSettings`, the constants set, the parsed
document: :class:`SceneCommon`) and ``kind_spec``, the kind's own record (one of
:data:`dpfexplore.inverse.kinds.KindSpec`: the position kinds' targets, the gripper's apertures,
the timing scenes' requirements). ``SceneSpec[K]`` names the kind spec's type, so that each kind's
functions annotate the scene they take (``SceneSpec[GripperSpec]``). Scene files are read into
these records by :mod:`dpfexplore.inverse.scene_file` (the shared tables) and each kind's parser
(its own tables).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Generic, TypeVar

from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.variables import DesignVariables
from .engine.settings import OptimiserSettings

__all__ = ["OptimiserSettings", "SceneCommon", "SceneSpec"]

#: The type of a scene's kind spec.
K = TypeVar("K")


@dataclass(frozen=True)
class SceneCommon:
    """The parts of a scene every kind shares (the file's keys are in :mod:`~.scene_file`).

    A kind's parser receives these, read and checked, and returns its kind spec.

    Attributes
    ----------
    kind, name, description : str
    seed : int
    E, nu : float
        Material (MPa, 1).
    material : str
        Preset key, or ``""`` when ``E`` was given.
    n_units : tuple of int
        The numbers of units searched (a kind with its own variables sets them).
    variables : dict
        :class:`DesignVariables` fields other than ``n_units``, ``E`` and ``nu``.
    optimiser : OptimiserSettings
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
    optimiser: OptimiserSettings = field(default_factory=OptimiserSettings)
    document: dict[str, Any] = field(default_factory=dict, compare=False)
    constants: ConstantsSet = DEFAULT

    def design_variables(self, n_units: int) -> DesignVariables:
        """The design variables of ``n_units``-unit designs."""
        return DesignVariables(
            n_units=n_units, E=self.E, nu=self.nu, constants=self.constants, **self.variables
        )


@dataclass(frozen=True)
class SceneSpec(SceneCommon, Generic[K]):
    """A validated scene: the shared parts (:class:`SceneCommon`) and the kind's own spec.

    Attributes
    ----------
    kind_spec : K
        The kind's record (:data:`dpfexplore.inverse.kinds.KindSpec`), e.g.
        :class:`~dpfexplore.inverse.scenes.position.spec.PositionSpec` for ``kind = "position"``.
        Its ``n_results`` is the number of result rows the scene reports.

    Notes
    -----
    ``targets`` (the position kinds' :class:`~.scenes.position.spec.Target` points, else empty)
    and ``gripper``, ``pickplace``, ``walker`` (the kind spec of a scene of that kind, else
    None) read the kind spec under the names the scene file's tables have.
    """

    kind_spec: K = field(kw_only=True)

    @classmethod
    def of(cls, common: SceneCommon, kind_spec: K) -> SceneSpec[K]:
        """The scene of the shared parts ``common`` and the kind spec ``kind_spec``."""
        return cls(
            **{f.name: getattr(common, f.name) for f in fields(SceneCommon)}, kind_spec=kind_spec
        )

    @property
    def targets(self) -> tuple:
        """The targets of a position scene (empty for the other kinds)."""
        return self.kind_spec.targets if self.kind in ("position", "position_stiffness") else ()

    @property
    def gripper(self) -> Any:
        """The kind spec of a gripper scene (None for the other kinds)."""
        return self.kind_spec if self.kind == "gripper" else None

    @property
    def pickplace(self) -> Any:
        """The kind spec of a pick-and-place scene (None for the other kinds)."""
        return self.kind_spec if self.kind == "pickplace" else None

    @property
    def walker(self) -> Any:
        """The kind spec of a walker-leg scene (None for the other kinds)."""
        return self.kind_spec if self.kind == "walker_leg" else None
