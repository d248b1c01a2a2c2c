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
sort
    :func:`sort_objects`: the size-and-weight loop over many objects (in parallel), the
    confusion table; :func:`sorting_map` over a grid of diameters and masses.
classes
    Object classes (diameter and mass ranges): each class's margin to the loop's boundaries
    (:func:`~.classes.class_margins`) and objects sampled from each.
"""

from .grasp import GraspReport, StateGrasp, grasp
from .setup import GraspOptions, Gripper, gripper_of
from .sort import Objects, SortedObject, SortReport, read_objects, sort_objects, sorting_map

__all__ = [
    "GraspOptions",
    "GraspReport",
    "Gripper",
    "Objects",
    "SortReport",
    "SortedObject",
    "StateGrasp",
    "grasp",
    "gripper_of",
    "read_objects",
    "sort_objects",
    "sorting_map",
]
