"""Limits of the design domain shared by the model, the kernels and the sweeps.

Kept apart from :mod:`dpfexplore.model.design` so that the Numba kernels, which size their
workspaces by these limits, depend only on plain constants and never on the Python design
objects.
"""

from __future__ import annotations

#: Largest number of units a design may have (MODEL.md §2: ``N`` from 1 to 12).
MAX_UNITS = 12
