"""Whether a design lies where the closed forms of MODEL.md §3 were fitted.

The spring constants are regressions on finite-element runs of domes with ``H`` in [3, 5] mm,
``t`` in [0.5, 1] mm and ``E`` in [5, 40] MPa. Outside that box they still give numbers (the
walker leg's ``H = 1.1`` and ``2.0`` domes, for instance), but nothing vouches for them: every
output that reports such a design says so.

This module is the stand-in for ``Design.in_fitted_range`` and ``Design.fitted_range_note``
of the hardening work (``dpfexplore.model.domain.FITTED_RANGES``); when those land,
:func:`fitted_range` becomes a call to them and nothing else changes.
"""

from __future__ import annotations

from ..model.design import Design

__all__ = ["FITTED_RANGES", "fitted_range"]

#: Where the closed forms were fitted: parameter -> (low, high), mm or MPa.
FITTED_RANGES: dict[str, tuple[float, float]] = {"H": (3.0, 5.0), "t": (0.5, 1.0), "E": (5.0, 40.0)}


def fitted_range(design: Design) -> tuple[bool, str | None]:
    """``(inside, note)``: whether every ``H``, ``t`` and ``E`` is in :data:`FITTED_RANGES`.

    ``note`` names each value outside its range (None when inside), e.g.
    ``"H[unit 1] = 1.1 mm outside [3, 5] mm (fitted range of the closed forms)"``.
    """
    problems = []
    low, high = FITTED_RANGES["H"]
    for k, H in enumerate(design.H):
        if not low <= H <= high:
            problems.append(f"H[unit {k + 1}] = {H:g} mm outside [{low:g}, {high:g}] mm")
    for name, unit in (("t", "mm"), ("E", "MPa")):
        low, high = FITTED_RANGES[name]
        value = getattr(design, name)
        if not low <= value <= high:
            problems.append(f"{name} = {value:g} {unit} outside [{low:g}, {high:g}] {unit}")
    if not problems:
        return True, None
    return False, "; ".join(problems) + " (fitted range of the closed forms, MODEL.md §3)"
