"""Helpers shared by the model, solver and sensitivity tests (imported by name: tests is on the
path, see pyproject's pytest ``pythonpath``)."""

from __future__ import annotations

from scipy.optimize import brentq

from dpfexplore.model.constants import dome_alpha, dome_radius


def height_for_alpha(target: float, t: float = 0.83, r_b: float = 5.0) -> float:
    """Dome height whose α equals ``target`` (α falls with H on [2.5, 3.5] at t = 0.83)."""
    return brentq(lambda H: dome_alpha(H, t, dome_radius(H, r_b)) - target, 2.5, 3.5, xtol=1e-15)
