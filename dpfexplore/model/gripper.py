"""Scenes that place fingers in a robot: the paper's multi-aperture gripper (MODEL.md §7).

The gripper holds two mirrored fingers on a base. In the implementation's frame a finger is
shifted by ``-h`` (limiting layer on ``y = 0``), rotated by the base angle ``θ_B`` about the
origin, and mirrored about ``y = Base_L``; the aperture is the gap between the two tips,
``2 (Base_L - y_tip)``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["PAPER_GRIPPER_BASE", "gripper_aperture", "gripper_frame"]

#: Base length (mm) and base angle (degrees) of the paper's multi-aperture gripper.
PAPER_GRIPPER_BASE = (20.081, -27.065)


def gripper_frame(points: ArrayLike, h: float, base_angle_deg: float) -> NDArray:
    """Points of a finger (model frame, mm) in the gripper frame: shifted by ``-h``, rotated."""
    points = np.asarray(points, dtype=float)
    theta = math.radians(base_angle_deg)
    rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    return (points - np.array([0.0, h])) @ rotation.T


def gripper_aperture(
    tip: ArrayLike, h: float, base_length: float, base_angle_deg: float
) -> NDArray:
    """Gap between the two fingertips of the gripper, ``2 (Base_L - y_tip)`` (mm).

    Parameters
    ----------
    tip : array_like of shape (..., 2), mm
        Tip position(s) ``L_N`` in the model frame (MODEL.md §5).
    h : float, mm
        Segment height of the finger.
    base_length : float, mm
        ``Base_L``: half the distance between the finger bases' mirror line and the origin.
    base_angle_deg : float, degrees
        ``θ_B``: rotation of each finger about its base.
    """
    y_tip = gripper_frame(tip, h, base_angle_deg)[..., 1]
    return 2.0 * (base_length - y_tip)
