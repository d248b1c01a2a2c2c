"""Inverse design: from what a finger must do to verified designs.

A new scene kind is one package under ``scenes/`` and one entry of
:data:`~.kinds.SCENE_KINDS`; nothing else changes (the recipe, with an example kind:
``docs/guide/scenes.md``, "Adding a scene kind").

kinds
    :data:`~.kinds.SCENE_KINDS`: one record per scene kind, listed in one literal table, and
    :func:`load_scene` / :func:`parse_scene`.
scene_kind
    What a kind is (:class:`~.scene_kind.SceneKind`) and what its results offer.
spec
    What a scene is: the parts every kind shares and the kind's own spec, as records.
scene_file
    Scene files (TOML): the tables every kind shares, read and validated (the fields by
    :mod:`dpfexplore.io.toml_fields`); :class:`SceneSpecError`. Design variables
    (:class:`~dpfexplore.model.variables.DesignVariables`) come from the model stage, which
    lookup shares.
evaluation
    :class:`SceneEvaluator`: every exact model solve of a scene, counted by kind and recorded.
engine
    Scene-agnostic numerics (imports no scene, reads no kind): problems, candidates,
    trust-region refinement, fronts, roots, differences.
scenes
    One package per scene kind: its spec, problem, solve, report, text summary and record.
report
    What every kind's report shares: verified re-solves, the summary and history files.
design
    :func:`design_scene`: the loop over a scene's result rows; :func:`run_design` writes them.
"""

from ..model.variables import DesignVariables
from .design import design_scene, run_design
from .kinds import load_scene, parse_scene
from .scene_file import SceneSpecError
from .spec import SceneSpec

__all__ = [
    "DesignVariables",
    "SceneSpec",
    "SceneSpecError",
    "design_scene",
    "load_scene",
    "parse_scene",
    "run_design",
]
