"""Shipped examples (TOML), found with :func:`example_path`.

Designs (a ``[design]`` table): ``gripper``, ``pickplace``. Legs (MODEL.md §10, read by
:func:`dpfexplore.solvers.legs.leg.load_leg`): ``walker-leg`` (the implementation's leg with
``H_p = 1.1``) and ``walker-leg-2.5`` (``H_p = 2.5``).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

NAMES = ("gripper", "pickplace", "walker-leg", "walker-leg-2.5")


def example_path(name: str) -> Path:
    """Path of a shipped example, e.g. ``example_path("gripper")``."""
    if name not in NAMES:
        raise ValueError(f"example = {name!r}: choose one of {NAMES}")
    return Path(str(resources.files(__package__) / f"{name}.toml"))
