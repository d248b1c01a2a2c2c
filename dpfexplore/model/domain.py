"""The design domain: what the model accepts, and where its closed forms were fitted.

Kept apart from :mod:`dpfexplore.model.design` so that the Numba kernels, which size their
workspaces by :data:`MAX_UNITS`, depend only on plain constants and never on the Python design
objects. Everything here is NumPy on plain arrays; :mod:`~dpfexplore.model.design` turns it into
messages, status codes and the ``in_fitted_range`` API.

Physical domain (rejected outside)
    The lattice of MODEL.md §5 describes a finger whose domes are spherical caps of base radius
    ``r_b`` sitting in units of length ``U_L``. Two geometries are not such a finger, and the
    model gives wrong answers on them without failing, so they are rejected: ``ValueError``
    naming the field for a :class:`~dpfexplore.model.design.Design`, status
    ``OUTSIDE_DOMAIN`` (with the reason in ``problem``) for a row of a batch or a sweep.

    * ``H_k <= r_b``: a dome taller than its base radius is more than a hemisphere, not a cap
      that snaps through its base plane. The closed forms then give a reach ``d`` of more
      than ``1.14 r_b``, so an inverted unit turns the finger by more than ``atan(d/h)`` = 37°
      (``h = 1.5 r_b + t_lim + t``), lattices fold over themselves, and one inversion vector
      has several minima: with ``H = [50, 50, 50]`` (``U_L = 8``) ``dpfexplore states``
      reported rows "collapsed to 000" with energies of 17 and 34 N·mm where the ``000`` row
      has 0, and tips at ``x < 0``. Random designs with ``r_b < H <= 2.5 r_b`` still give
      such rows (9 of 17,498 collapsed rows); with ``H <= r_b`` none were found in about
      250,000 collapsed rows of 2-6 unit fingers over wide ranges of every other parameter
      (``tests/model/test_domain.py`` keeps checking it with hypothesis).
    * ``H_k < U_L_k``: a dome at least as tall as its unit is long fills the unit; there is no
      room for it. (The model itself does not fail there, but no finger looks like that.)

    The paper's box (``H`` 3-5 mm, ``U_L`` 5.5-10 mm, ``r_b`` = 5 mm) and the implementation's
    walker legs (``H`` 1.1-4.5 mm, ``U_L`` = 6.5 mm) lie inside.

Fitted range (flagged, never rejected)
    The closed forms of MODEL.md §3 (``k_b``, ``alpha`` and the reach ``d``) are regressions
    of finite-element results on the paper's unit geometry: :data:`FITTED_RANGES`. Inside the
    domain but outside these ranges the answer is an extrapolation: every result carries the
    flag (``Design.in_fitted_range``, ``fitted_range`` in JSON output and sweep datasets) and a
    one-line note saying what is outside (``Design.fitted_range_note``). The beam constants
    (``k_lim``, ``k_post``, ``k_t``) and the lattice lengths are mechanics, not fits, so
    ``U_L``, ``U_sep`` and ``t_lim`` have no fitted range.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable
from numpy.typing import NDArray

from .limits import MAX_UNITS  # re-exported: defined where front ends need no Numba

#: Ranges the closed forms of MODEL.md §3 were fitted on: ``name: (low, high, unit)``.
#: ``H`` and ``t``: the paper's Table var_ranges, on which the regressions were fitted (MODEL.md
#: §3; the implementation's own walker leg uses H = 1.1 and 2.0 mm, outside). ``E``: the moduli
#: the regressions cover (MODEL.md §2). ``r_b``: the paper's only base radius (unit cell
#: UC = 3 r_b = 15 mm); ``k_b`` and ``alpha`` depend on it through the dome radius ``R``.
FITTED_RANGES: dict[str, tuple[float, float, str]] = {
    "H": (3.0, 5.0, "mm"),
    "t": (0.5, 1.0, "mm"),
    "E": (5.0, 40.0, "MPa"),
    "r_b": (5.0, 5.0, "mm"),
}


def active_units(n_units: NDArray) -> NDArray[np.bool_]:
    """``(n, MAX_UNITS)`` mask of the units each design has (padding False)."""
    n_units = np.clip(np.asarray(n_units), 0, MAX_UNITS)
    return np.arange(MAX_UNITS)[None, :] < n_units[:, None]


@register_jitable
def unit_in_domain(H, U_L, r_b):
    """Whether one unit lies in the physical domain: ``H <= r_b`` and ``H < U_L`` (mm).

    The scalar form of :func:`outside_domain`, compiled into the kernel that validates and
    packs batches (:mod:`dpfexplore._kernels.tables`) and run as Python by ``Design``.
    """
    return H <= r_b and H < U_L


def outside_domain(
    H: NDArray, U_L: NDArray, r_b: NDArray, active: NDArray
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Units outside the physical domain (module docstring), per rule.

    Parameters
    ----------
    H, U_L : ndarray of shape (n, MAX_UNITS), mm
    r_b : ndarray of shape (n,), mm
    active : ndarray of bool, shape (n, MAX_UNITS)
        Units the designs have (:func:`active_units`).

    Returns
    -------
    taller_than_base, taller_than_unit : ndarray of bool, shape (n, MAX_UNITS)
        ``H_k > r_b`` and ``H_k >= U_L_k`` on active units.
    """
    with np.errstate(invalid="ignore"):
        taller_than_base = active & (H > np.asarray(r_b)[:, None])
        taller_than_unit = active & (H >= U_L)
    return taller_than_base, taller_than_unit


def _describe(name: str, value: float, low: float, high: float, unit: str) -> str:
    where = "below" if value < low else "above"
    span = f"{low:g} {unit}" if low == high else f"{low:g}-{high:g} {unit}"
    return f"{name} = {value:g} {unit} {where} the fitted {span}"


def fitted_range(
    n_units: NDArray, H: NDArray, shared: dict[str, NDArray]
) -> tuple[NDArray[np.bool_], list[str | None]]:
    """Which designs lie in :data:`FITTED_RANGES`, and a note on those that do not.

    Parameters
    ----------
    n_units : ndarray of int, shape (n,)
    H : ndarray of shape (n, MAX_UNITS), mm
        Dome heights (padding ignored).
    shared : dict of str to ndarray of shape (n,)
        ``t``, ``E`` and ``r_b``.

    Returns
    -------
    inside : ndarray of bool, shape (n,)
        True when every unit's ``H`` and the shared ``t``, ``E``, ``r_b`` are in range (NaN
        values count as outside).
    notes : list of (str or None)
        One line per design naming what is outside, e.g. ``"H[unit 1] = 1.1 mm below the
        fitted 3-5 mm"``; None when inside.
    """
    active = active_units(n_units)
    low, high, _ = FITTED_RANGES["H"]
    with np.errstate(invalid="ignore"):
        bad_H = active & ~((H >= low) & (H <= high))
        bad_shared = {
            name: ~((shared[name] >= lo) & (shared[name] <= hi))
            for name, (lo, hi, _) in FITTED_RANGES.items()
            if name != "H"
        }
    inside = ~bad_H.any(axis=1)
    for bad in bad_shared.values():
        inside &= ~bad
    notes: list[str | None] = [None] * len(inside)
    for i in np.flatnonzero(~inside):
        parts = []
        units = np.flatnonzero(bad_H[i])
        if units.size:
            k = int(units[0])
            text = _describe(f"H[unit {k + 1}]", float(H[i, k]), *FITTED_RANGES["H"])
            if units.size > 1:
                text += f" (and {units.size - 1} more unit{'s' if units.size > 2 else ''})"
            parts.append(text)
        for name, bad in bad_shared.items():
            if bad[i]:
                parts.append(_describe(name, float(shared[name][i]), *FITTED_RANGES[name]))
        notes[i] = "; ".join(parts)
    return inside, notes
