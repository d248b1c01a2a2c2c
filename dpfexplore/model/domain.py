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


def unit_in_domain(H, U_L, r_b):
    """Whether one unit lies in the physical domain: ``H <= r_b`` and ``H < U_L`` (mm).

    The scalar form of :func:`outside_domain`, compiled into the kernel that validates and
    packs batches (:mod:`dpfexplore._kernels.tables.design_tables`) and run as Python by ``Design``.
    """
    return H <= r_b and H < U_L


#: The functions of this module that the kernels compile inline
#: (:mod:`dpfexplore._kernels.tables.model_forms`).
COMPILED_INLINE = (unit_in_domain,)


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


#: Names of the quantities a fitted range may bound, as notes write them.
RANGE_LABELS = {"H_over_rb": "H/r_b", "t_over_rb": "t/r_b"}
#: Units of the quantities a fitted range may bound.
RANGE_UNITS = {"H": "mm", "t": "mm", "r_b": "mm", "E": "MPa"}


def _describe(name: str, value: float, low: float, high: float, unit: str) -> str:
    where = "below" if value < low else "above"
    unit_text = f" {unit}" if unit else ""
    span = f"{low:g}{unit_text}" if low == high else f"{low:g}-{high:g}{unit_text}"
    return f"{name} = {value:g}{unit_text} {where} the fitted {span}"


def fitted_range(
    n_units: NDArray,
    values: dict[str, NDArray],
    ranges: dict[str, tuple[float, float]],
) -> tuple[NDArray[np.bool_], list[str | None]]:
    """Which designs lie in a constants set's fitted ranges, and a note on those that do not.

    Parameters
    ----------
    n_units : ndarray of int, shape (n,)
    values : dict of str to ndarray
        The bounded quantities by name: per unit ``(n, MAX_UNITS)`` (``H``, ``H_over_rb``;
        padding ignored) or shared ``(n,)`` (``t``, ``r_b``, ``E``, ``nu``, ``t_over_rb``).
    ranges : dict of str to (float, float)
        The set's domain (:attr:`dpfexplore.model.constants_set.ConstantsSet.domain`); for the
        paper's set, :data:`FITTED_RANGES`.

    Returns
    -------
    inside : ndarray of bool, shape (n,)
        True when every bounded quantity of every unit is in range (NaN counts as outside).
    notes : list of (str or None)
        One line per design naming what is outside, e.g. ``"H[unit 1] = 1.1 mm below the
        fitted 3-5 mm"``; None when inside.
    """
    active = active_units(n_units)
    inside = np.ones(np.asarray(n_units).shape[0], dtype=bool)
    bad: dict[str, NDArray] = {}
    with np.errstate(invalid="ignore"):
        for name, (lo, hi) in ranges.items():
            value = np.asarray(values[name], dtype=float)
            out = ~((value >= lo - 1e-12 * abs(lo)) & (value <= hi + 1e-12 * abs(hi)))
            bad[name] = active & out if value.ndim == 2 else out
            inside &= ~(bad[name].any(axis=1) if value.ndim == 2 else bad[name])
    notes: list[str | None] = [None] * len(inside)
    for i in np.flatnonzero(~inside):
        parts = []
        for name, mask in bad.items():
            label, unit = RANGE_LABELS.get(name, name), RANGE_UNITS.get(name, "")
            lo, hi = ranges[name]
            if mask.ndim == 2:
                units = np.flatnonzero(mask[i])
                if not units.size:
                    continue
                k = int(units[0])
                text = _describe(f"{label}[unit {k + 1}]", float(values[name][i, k]), lo, hi, unit)
                if units.size > 1:
                    text += f" (and {units.size - 1} more unit{'s' if units.size > 2 else ''})"
                parts.append(text)
            elif mask[i]:
                parts.append(_describe(label, float(values[name][i]), lo, hi, unit))
        notes[i] = "; ".join(parts)
    return inside, notes
