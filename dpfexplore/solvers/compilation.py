"""Which kernels a command needs, whether they are compiled yet, and a notice when they are not.

Numba compiles each kernel on its first call and keeps the machine code in its cache
(:mod:`dpfexplore._kernels._cache`), so only the first run after an install (or an edit of the
kernels) compiles. That first run is slow and would otherwise be silent: the CLI prints
:func:`compile_notice` before it starts, and the Python API (:func:`announce`, called by the
solvers before their kernels) logs it once per process as a WARNING on the ``dpfexplore`` logger,
which Python shows on stderr even when logging is not configured.

Compile cost per group, measured in a fresh process with an empty cache on the 2-core AMD EPYC
VM of the README's benchmarks (CPU seconds; wall time is longer on a loaded machine):

* ``states``: ``states``, ``find_state`` (one design, serial kernels), ~23 s;
* ``statics``: every ``sweep``, ``solve_batch`` (parallel kernels), ~22 s;
* ``sensitivities``: ``find_state(..., sensitivities=True)``, ``lookup --refine``, ~14 s
  (37 s with ``states``);
* ``snap``: ``snap``, ``snap_pressures``, ~28 s (51 s with ``states``);
* ``dynamics``: ``simulate``, ~20 s;
* ``reset``: ``sweep`` with reset times, ``reset-maps``, batches, ~20 s;
* ``unit-cell shell``: ``unitcell curve``, ``unit_cell_curve`` (the shell model of one dome),
  ~27 s (63 s wall on a loaded VM);
* ``unit-cell contact``: ``two_unit_rest`` (the dome against its neighbour's wall), ~7 s once
  ``unit-cell shell`` is compiled.

A group shares most of its code with the others (the lattice assembly, the linear algebra), so
a second group costs less once the first is compiled.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable

from .._kernels._cache import is_cached
from .._kernels.dynamics import batch as dynamics_batch
from .._kernels.grasp import batch as grasp_batch
from .._kernels.grasp import equilibrium as grasp_equilibrium
from .._kernels.reset import reduced
from .._kernels.sensitivity import batch as sensitivity_batch
from .._kernels.shell import contact as shell_contact
from .._kernels.shell import path as shell_path
from .._kernels.snap import walk as ksnap
from .._kernels.statics import batch

__all__ = ["COMPILE_CPU_S", "KERNEL_GROUPS", "announce", "compile_notice", "uncompiled"]

logger = logging.getLogger("dpfexplore.compile")

#: The entry kernels of each group (their callees are compiled with them).
KERNEL_GROUPS = {
    # one design runs the serial twins (a batch of a few rows is not worth the threads); the
    # node positions find_state adds (kstates.nodes_of) compile in under a second of CPU, and a
    # group must hold only what its announcer runs, or a process that never calls them would
    # announce a compilation on every start
    "states": (batch.solve_rows_serial,),
    "statics": (batch.solve_rows,),
    "dynamics": (dynamics_batch.integrate,),
    "reset": (dynamics_batch.reset_times_kernel,),
    "release": (reduced.release_batch,),
    "sensitivities": (sensitivity_batch.solve_rows_sensitivities_serial,),
    "snap": (ksnap.follow,),
    "unit-cell shell": (shell_path.follow,),
    "unit-cell contact": (shell_contact.rest_on_wall, shell_contact.polish_on_wall),
    "grasp": (grasp_equilibrium.grasp_solve, grasp_batch.pull_out),
    "grasp sort": (grasp_batch.sort_batch,),
}
#: Groups this process has announced or found compiled: checked once, never again.
_SETTLED: set[str] = set()
#: Measured first-compile CPU seconds per group (module docstring).
COMPILE_CPU_S = {
    "sensitivities": 14,
    "snap": 28,
    "states": 23,
    "statics": 22,
    "dynamics": 20,
    "reset": 20,
    "release": 20,
    "unit-cell shell": 27,
    "unit-cell contact": 7,
    "grasp": 10,
    "grasp sort": 7,
}


def uncompiled(groups: Iterable[str]) -> list[str]:
    """The groups among ``groups`` some of whose kernels have no cached machine code."""
    missing = []
    for group in groups:
        if any(is_cached(kernel) is False for kernel in KERNEL_GROUPS[group]):
            missing.append(group)
    return missing


def compile_notice(groups: Iterable[str]) -> str | None:
    """One line announcing a first compilation of ``groups``, or None if all are cached.

    Groups named here count as announced for the rest of the process (:func:`announce` stays
    quiet about them), so the CLI's notice and the API's log line never both appear.
    """
    groups = [g for g in groups if g not in _SETTLED]
    missing = uncompiled(groups)
    _SETTLED.update(groups)
    if not missing:
        return None
    seconds = sum(COMPILE_CPU_S[group] for group in missing)
    names = " and ".join(missing)
    return (
        f"compiling the {names} kernels for this machine (first run only: about {seconds} s "
        f"of CPU, a few minutes on a busy machine; later runs load them from the Numba cache)"
    )


def announce(groups: Iterable[str]) -> None:
    """Log a first compilation of ``groups`` once per process (WARNING, ``dpfexplore.compile``).

    Cheap after the first call of a group in a process: a set lookup, no cache inspection.
    """
    pending = [g for g in groups if g not in _SETTLED]
    if not pending:
        return
    notice = compile_notice(pending)
    if notice is not None:
        logger.warning("%s ...", notice)
