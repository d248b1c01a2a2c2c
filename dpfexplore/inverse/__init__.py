"""Inverse design: from what a finger must do to verified designs.

kinds
    :data:`~.kinds.SCENE_KINDS`: one record per scene kind (tables, parser, solver, report,
    writer), and :func:`load_scene` / :func:`parse_scene`.
spec
    What a scene is: targets, variables, material, objective, budget, as records.
scene_file, spec_fields
    Scene files (TOML): the format of the shape kinds, read and validated into a scene spec; the
    field readers every scene format shares.
    Design variables (:class:`~dpfexplore.sweep.variables.DesignVariables`) come from the sweep
    stage, which lookup shares.
evaluation
    :class:`SceneEvaluator`: every exact model solve of a scene, counted by kind and recorded.
problem
    The problems of the shape scenes: residuals and stiffness of box points.
engine
    Scene-agnostic numerics: candidates, trust-region refinement, fronts, differences.
scenes
    One package per timing or gripper scene kind (gripper, pickplace, walker).
report
    Verification of every reported design and the report files of the shape scenes.
design
    :func:`design_scene`: the loop over a scene's targets.
"""

from ..model.variables import DesignVariables
from .design import design_scene, run_design
from .kinds import load_scene, parse_scene
from .spec import SceneSpec
from .spec_fields import SceneSpecError

__all__ = [
    "DesignVariables",
    "SceneSpec",
    "SceneSpecError",
    "design_scene",
    "load_scene",
    "parse_scene",
    "run_design",
]
