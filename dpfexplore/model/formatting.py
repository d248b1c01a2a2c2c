"""Numbers as users read them.

In messages ``-0.83``, not ``np.float64(-0.83)``; in JSON ``null`` for "no value" and ``"inf"``
for an unbounded time, not the invalid ``NaN`` / ``Infinity``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

__all__ = ["json_number", "num", "nums"]


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


def json_number(value: Any) -> float | str | None:
    """A number for JSON: ``None`` and NaN as ``None``, ``±inf`` as ``"inf"`` / ``"-inf"``."""
    if value is None:
        return None
    value = float(value)
    if math.isnan(value):
        return None
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value
