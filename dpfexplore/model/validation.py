"""The validation of designs: status codes and the one-line description of a design's problem.

:func:`problems` checks padded batch arrays with NumPy and names each bad design's first
problem; :func:`geometry_status` and :func:`constants_status` are the same rules for one design
in plain arithmetic, compiled inline by the kernel that packs batches
(:mod:`dpfexplore._kernels.tables.design_tables`) and run as Python by :func:`status_code` (a
:class:`Design` checks itself with it). The rules, in order: ``N`` in 1..MAX_UNITS, finite positive
lengths and ``E``, ``0 <= nu < 0.5`` (``INVALID_INPUT``); the physical domain of
:mod:`dpfexplore.model.domain` (``OUTSIDE_DOMAIN``); ``k_b > 0`` and ``0 < alpha < 1`` under
the constants set (``INVALID_CONSTANTS``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from . import status as st
from .constants import constants_are_valid
from .constants_set import DEFAULT, ConstantsSet
from .domain import MAX_UNITS, active_units, outside_domain, unit_in_domain
from .formatting import num as _num

__all__ = [
    "PER_UNIT_FIELDS",
    "SHARED_FIELDS",
    "constants_status",
    "geometry_status",
    "problems",
    "status_code",
]

#: The per-unit fields of a design (mm), in the order of the kernels.
PER_UNIT_FIELDS = ("H", "U_L", "U_sep")
#: The fields every unit of a design shares (mm, MPa), in the order of the kernels.
SHARED_FIELDS = ("t", "t_lim", "E", "nu", "r_b", "t_ch")


def problems(
    n_units: NDArray,
    per_unit: Mapping[str, NDArray],
    shared: Mapping[str, NDArray],
    constants: ConstantsSet,
) -> tuple[NDArray, list[str | None]]:
    """Vectorised validation of padded design arrays.

    Returns each design's status code (``OK``, ``INVALID_INPUT``, ``OUTSIDE_DOMAIN`` or
    ``INVALID_CONSTANTS``) and a one-line description of its first problem (None when valid).
    """
    n = n_units.shape[0]
    code = np.full(n, st.OK, dtype=np.int8)
    message: list[str | None] = [None] * n

    def flag(mask: NDArray, status: int, describe) -> None:
        for i in np.flatnonzero(mask & (code == st.OK)):
            code[i] = status
            message[i] = describe(i)

    n_ok = (n_units >= 1) & (n_units <= MAX_UNITS)
    flag(
        ~n_ok,
        st.INVALID_INPUT,
        lambda i: f"N = {_num(n_units[i])}: must be between 1 and {MAX_UNITS}",
    )
    active = active_units(n_units)
    for name in PER_UNIT_FIELDS:
        values = per_unit[name]
        bad = active & ~(np.isfinite(values) & (values > 0.0))

        def describe(i, name=name, values=values, bad=bad):
            k = int(np.flatnonzero(bad[i])[0])
            return f"{name}[unit {k + 1}] = {_num(values[i, k])}: must be a finite length > 0 mm"

        flag(bad.any(axis=1), st.INVALID_INPUT, describe)
    for name in SHARED_FIELDS:
        values = shared[name]
        if name == "nu":
            bad = ~(np.isfinite(values) & (values >= 0.0) & (values < 0.5))
            rule = "must be finite, 0 <= nu < 0.5"
        else:
            bad = ~(np.isfinite(values) & (values > 0.0))
            rule = "must be finite and > 0" + (" MPa" if name == "E" else " mm")
        flag(
            bad,
            st.INVALID_INPUT,
            lambda i, name=name, v=values, r=rule: f"{name} = {_num(v[i])}: {r}",
        )
    # The physical domain (model/domain.py): geometries that are not a finger of caps in units.
    taller_than_base, taller_than_unit = outside_domain(
        per_unit["H"], per_unit["U_L"], shared["r_b"], active
    )

    def describe_base(i):
        k = int(np.flatnonzero(taller_than_base[i])[0])
        return (
            f"H[unit {k + 1}] = {_num(per_unit['H'][i, k])} mm: taller than the dome base radius "
            f"r_b = {_num(shared['r_b'][i])} mm (more than a hemisphere; outside the model's "
            "domain, see dpfexplore.model.domain)"
        )

    def describe_unit(i):
        k = int(np.flatnonzero(taller_than_unit[i])[0])
        return (
            f"H[unit {k + 1}] = {_num(per_unit['H'][i, k])} mm: not shorter than its unit, "
            f"U_L[unit {k + 1}] = {_num(per_unit['U_L'][i, k])} mm (the dome leaves no room; "
            "outside the model's domain, see dpfexplore.model.domain)"
        )

    flag(taller_than_base.any(axis=1), st.OUTSIDE_DOMAIN, describe_base)
    flag(taller_than_unit.any(axis=1), st.OUTSIDE_DOMAIN, describe_unit)
    # The closed forms of MODEL.md §3 leave their fitted domain silently; catch the nonsense.
    with np.errstate(all="ignore"):
        H = np.where(active, per_unit["H"], 1.0)
        values = constants.evaluate(
            H, shared["t"][:, None], shared["r_b"][:, None], shared["E"][:, None]
        )
        k_b, alpha = values["k_b"], values["alpha"]
    bad_const = active & ~constants_are_valid(k_b, alpha)
    which = "closed forms"
    if constants != DEFAULT:
        which += f" of constants set {constants.label}"

    def describe_const(i):
        k = int(np.flatnonzero(bad_const[i])[0])
        return (
            f"H[unit {k + 1}] = {_num(H[i, k])} with t = {_num(shared['t'][i])}: the {which} "
            "give "
            f"k_b = {k_b[i, k]:.4g} N/mm, alpha = {alpha[i, k]:.4g} "
            "(need k_b > 0 and 0 < alpha < 1; outside the fitted domain)"
        )

    flag(bad_const.any(axis=1), st.INVALID_CONSTANTS, describe_const)
    return code, message


def _positive(v):
    return math.isfinite(v) and v > 0.0


def geometry_status(n_units, H, U_L, U_sep, shared):
    """Status code of one design's inputs and geometry (all of :func:`status_code` but constants).

    ``H``, ``U_L``, ``U_sep``: sequences of at least ``n_units`` values (mm); ``shared``: the
    design's ``(t, t_lim, E, nu, r_b, t_ch)`` (:data:`SHARED_FIELDS`; ``SharedParams`` in the
    kernels). ``OK``, ``INVALID_INPUT`` or ``OUTSIDE_DOMAIN``. The kernel that packs batches
    (:mod:`dpfexplore._kernels.tables.design_tables`) runs this and checks the constants on the
    table rows it computes anyway, evaluating each closed form once.
    """
    t, t_lim, E, nu, r_b, t_ch = shared
    if not 1 <= n_units <= MAX_UNITS:
        return st.INVALID_INPUT
    for k in range(n_units):
        if not (_positive(H[k]) and _positive(U_L[k]) and _positive(U_sep[k])):
            return st.INVALID_INPUT
    if not (_positive(t) and _positive(t_lim) and _positive(E)):
        return st.INVALID_INPUT
    if not (math.isfinite(nu) and 0.0 <= nu < 0.5):
        return st.INVALID_INPUT
    if not (_positive(r_b) and _positive(t_ch)):
        return st.INVALID_INPUT
    for k in range(n_units):
        if not unit_in_domain(H[k], U_L[k], r_b):
            return st.OUTSIDE_DOMAIN
    return st.OK


def constants_status(k_b, alpha):
    """``OK`` where a unit's ``k_b`` and ``alpha`` make sense, else ``INVALID_CONSTANTS``."""
    if math.isfinite(k_b) and math.isfinite(alpha) and k_b > 0.0 and 0.0 < alpha < 1.0:
        return st.OK
    return st.INVALID_CONSTANTS


#: The functions of this module that the kernels compile inline
#: (:mod:`dpfexplore._kernels.tables.model_forms`): the rules for one design, in plain Python.
COMPILED_INLINE = (_positive, geometry_status, constants_status)


def status_code(n_units, H, U_L, U_sep, shared, constants: ConstantsSet):
    """Status code of one design under the rules of :func:`problems` (without the message).

    The rules of the kernel that packs batches (:func:`geometry_status` and
    :func:`constants_status`, compiled there), run here in plain Python with the set's own
    arithmetic (:meth:`~dpfexplore.model.constants_set.ConstantsSet.dome`):
    :class:`Design` checks itself at tens of microseconds where the vectorised
    :func:`problems` costs hundreds for any batch size; the tests hold the two to the same
    codes. Arguments as :func:`geometry_status`.
    """
    code = geometry_status(n_units, H, U_L, U_sep, shared)
    if code != st.OK:
        return code
    t, _, E, _, r_b, _ = shared
    for k in range(n_units):
        code = constants_status(*constants.dome(float(E), float(H[k]), float(t), float(r_b)))
        if code != st.OK:
            return code
    return st.OK
