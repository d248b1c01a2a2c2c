"""Grasp mechanics of the multi-aperture gripper and its size-and-weight sorting loop.

The gripper of MODEL.md §7 (two mirrored fingers on a base) closes on a rigid disk centred on
its axis; the fingers' equilibrium with frictionless normal contact gives contact forces, the
contact sensor's reading on unit 1 and whether each state holds; pulling the disk out along the
axis gives each state's payload (MODEL.md §12; docs/guide/grasp.md).

Modules
-------
setup
    The gripper (design, base, grasp states, the tip unit held inverted), the disk's frame and
    the solver's controls.
grasp
    :func:`grasp`: one object in every grasp state; :class:`GraspReport`.
"""

from .grasp import GraspReport, StateGrasp, grasp
from .setup import GraspOptions, Gripper, gripper_of

__all__ = [
    "GraspOptions",
    "GraspReport",
    "Gripper",
    "StateGrasp",
    "grasp",
    "gripper_of",
]
