"""Shipped example designs (TOML), readable with :func:`example_path`."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

NAMES = ("gripper", "pickplace")


def example_path(name: str) -> Path:
    """Path of a shipped example design, e.g. ``example_path("gripper")``."""
    if name not in NAMES:
        raise ValueError(f"example = {name!r}: choose one of {NAMES}")
    return Path(str(resources.files(__package__) / f"{name}.toml"))
