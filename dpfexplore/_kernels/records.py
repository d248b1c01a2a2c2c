"""Named records that kernels take instead of long positional argument lists (STYLE.md §12).

Numba compiles ``collections.namedtuple`` instances of arrays and scalars in nopython mode, at no
cost at run time: a record is passed as one struct and its fields are read by name. The classes
are defined here, at module level, because Numba's ``cache=True`` pickles a record's type by
reference to its class: a class made inside a function could not be found again by a later
process loading the cache. Python wrappers build a record once per call with plain Python
scalars of a fixed type (``float`` tolerances, ``int`` counts), so one record type means one
compiled signature.

Records shared by the statics and the dynamics kernels live here; a record that only one family
of kernels uses may live beside those kernels.
"""

from __future__ import annotations

from collections import namedtuple

#: The lattice of one design or of a batch: ``unit_params`` of shape ``(MAX_UNITS, N_COLS)`` (or
#: ``(n_designs, MAX_UNITS, N_COLS)``; columns in :mod:`.layout`) and the segment height ``h``
#: (mm; a float, or an array of shape ``(n_designs,)``).
Lattice = namedtuple("Lattice", ["unit_params", "h"])

#: Newton controls of the energy minimisation: gradient tolerance ``gtol`` (N), step tolerance
#: ``xtol`` (mm), iteration cap ``max_iter`` (int) and the largest step ``max_step`` (mm).
NewtonControls = namedtuple("NewtonControls", ["gtol", "xtol", "max_iter", "max_step"])

#: A piecewise-linear pressure profile: knot times ``t`` (s) and pressures ``p`` (MPa), arrays of
#: one length.
PressureKnots = namedtuple("PressureKnots", ["t", "p"])
