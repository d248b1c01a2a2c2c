"""Numbers as users read them.

In messages ``-0.83``, not ``np.float64(-0.83)``; in JSON ``null`` for "no value" and ``"inf"``
for an unbounded time, not the invalid ``NaN`` / ``Infinity``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

__all__ = ["json_number", "json_text", "num", "nums"]


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


def _json_ready(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, float | np.floating):
        return json_number(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_ready(value.tolist())
    return value


def json_text(document: Any, *, indent: int | None = 2) -> str:
    """``document`` as strict JSON, numbers through :func:`json_number` at any depth.

    Every ``--json`` output goes through here, so a strict parser (``json.loads`` with
    ``parse_constant`` refusing, JavaScript, jq) always accepts it: no ``NaN``/``Infinity``.
    """
    return json.dumps(_json_ready(document), indent=indent, allow_nan=False, default=str)
