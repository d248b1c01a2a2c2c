"""Inverse design: from what a finger must do to verified designs.

spec
    Scene files (TOML): kinds, targets, variables, objective, budget (:func:`load_scene`).
    Design variables (:class:`~dpfexplore.sweep.variables.DesignVariables`) come from the sweep
    stage, which lookup shares.
evaluation
    :class:`Evaluator`: every exact model solve of a scene, counted by kind and recorded.
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

from ..sweep.variables import DesignVariables
from .design import design_scene, run_design
from .spec import SceneSpec, SceneSpecError, load_scene, parse_scene

__all__ = [
    "DesignVariables",
    "SceneSpec",
    "SceneSpecError",
    "design_scene",
    "load_scene",
    "parse_scene",
    "run_design",
]
