"""Inverse design: from what a finger must do to verified designs.

variables
    :class:`DesignVariables`: bounds and constraints as an exact map of the unit box.
scene_jobs
    Scene files (TOML): kinds, targets, variables, objective, budget (:func:`load_scene`).
evaluation
    :class:`Evaluator`: every exact model solve of a scene, counted by kind and recorded.
derivatives
    Central differences in the box: the fallback where the exact sensitivities are undefined.
scenes
    The problems of each scene kind: residuals and stiffness of box points.
optimiser
    Latin hypercube for every N, trust-region refinement, SLSQP stiffness fronts.
gripper_design, windows
    The multi-aperture gripper scene; pressure windows from snap pressures.
design_report, design
    Verification of every reported design, the report files, :func:`design_scene`.
timing_jobs, reset_problem, pickplace_screen, pickplace_design, pickplace_front, timing_report
    The pick-and-place scene: reset times by design (screening, brackets, roots, fronts).
walker_design, walker_legs, walker_report, inversion
    The walker-leg scene: zones that keep time, legs composed from section runs, inversion
    pressures.
datasets
    What a sweep directory holds now: committed chunks, content checksum, verified reads.
lookup_index, lookup_store
    Nearest-neighbour index over a dataset's output columns; saved beside it, refused stale.
refine
    Polish a design with the exact model until its outputs meet a target (lookup's refinement).
lookup, design_files
    :func:`~.lookup.lookup`: query, refine, verify; candidates as ``[design]`` TOML files.
"""

from .design import design_scene, run_design
from .scene_jobs import SceneSpec, SceneSpecError, load_scene, parse_scene
from .variables import DesignVariables

__all__ = [
    "DesignVariables",
    "SceneSpec",
    "SceneSpecError",
    "design_scene",
    "load_scene",
    "parse_scene",
    "run_design",
]
