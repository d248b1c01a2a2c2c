"""Numbers in messages as users write them: ``-0.83``, not ``np.float64(-0.83)``."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

__all__ = ["num", "nums"]


def num(value: Any) -> str:
    """One value: NumPy and Python numbers print alike (``repr`` of the Python number)."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return repr(value)


def nums(values: Iterable[Any]) -> str:
    """A sequence of values as a list, ``[0.0, 1.0, 5.0]``."""
    return "[" + ", ".join(num(v) for v in values) + "]"
