"""Status codes shared by the kernels, the Python API and the stored datasets.

Kernels return these as plain integers (Numba reads the module-level constants as compile-time
literals); the API and the Parquet datasets expose them through :class:`Status`, whose names are
also stored as a dictionary-encoded string column.
"""

from __future__ import annotations

from enum import IntEnum

OK = 0
INVALID_INPUT = 1
INVALID_CONSTANTS = 2
NOT_CONVERGED = 3
COLLAPSED = 4
NONFINITE = 5
DEGENERATE_GEOMETRY = 6
UNSTABLE = 7
STEP_LIMIT = 8
NOT_COMPUTED = 9
OUTSIDE_DOMAIN = 10


class Status(IntEnum):
    """Outcome of evaluating one design (or one design-state, or one simulation).

    Attributes
    ----------
    OK
        Converged; every output of the row is finite and meaningful.
    INVALID_INPUT
        A design parameter is non-finite, non-positive or out of range (N outside 1-12, ...).
    INVALID_CONSTANTS
        The closed forms of MODEL.md §3 give nonsense for this geometry (``k_b <= 0``,
        ``alpha >= 1`` so that the dome energy is unbounded below).
    NOT_CONVERGED
        The Newton solver hit its iteration cap.
    COLLAPSED
        The requested stable state does not exist; the row's ``found`` state says where the
        finger settles instead (that state's outputs are in the row).
    NONFINITE
        A non-finite energy or gradient appeared during the solve.
    DEGENERATE_GEOMETRY
        Two connected nodes (nearly) coincide, so spring directions are undefined.
    UNSTABLE
        The solver stopped at a stationary point that is not a minimum.
    STEP_LIMIT
        A time integrator hit its step cap before the horizon.
    NOT_COMPUTED
        The output was not requested by the job (e.g. reset time of a bistable unit).
    OUTSIDE_DOMAIN
        The geometry is not a finger the model describes (:mod:`dpfexplore.model.domain`: a
        dome taller than its base radius or than its unit); nothing was solved.
    """

    OK = OK
    INVALID_INPUT = INVALID_INPUT
    INVALID_CONSTANTS = INVALID_CONSTANTS
    NOT_CONVERGED = NOT_CONVERGED
    COLLAPSED = COLLAPSED
    NONFINITE = NONFINITE
    DEGENERATE_GEOMETRY = DEGENERATE_GEOMETRY
    UNSTABLE = UNSTABLE
    STEP_LIMIT = STEP_LIMIT
    NOT_COMPUTED = NOT_COMPUTED
    OUTSIDE_DOMAIN = OUTSIDE_DOMAIN

    @property
    def label(self) -> str:
        """Lower-case name used in tables and Parquet files, e.g. ``"not_converged"``."""
        return self.name.lower()
