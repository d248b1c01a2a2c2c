"""Which kernels a command needs, whether they are compiled yet, a notice and progress when not.

Numba compiles each kernel on its first call and keeps the machine code in its cache
(:mod:`dpfexplore._kernels._cache`), so only the first run after an install (or an edit of the
kernels) compiles. That first run is slow and would otherwise be silent. :func:`compile_notice`
is the one notice, in one line, of every command (the CLI prints it before the work starts;
the Python API, :func:`announce`, logs it once per process as a WARNING on the ``dpfexplore``
logger, which Python shows on stderr even when logging is not configured); it also starts a
watcher of Numba's compilations that shows each group as a stage of the command's progress
display (:mod:`dpfexplore.io.progress`): ``compiling the states kernels, group 1/2`` with the
time and the CPU so far, never silent for more than a few seconds while Numba compiles.

:data:`COMPILE_CPU_S` holds what each group costs alone on an empty cache, in seconds of CPU
(not wall: on a machine other processes load, wall time says how busy it was; ``states``: 34 s
of CPU took 116 s of wall at load 9), measured by ``scripts/compile_cpu.py`` (each group in a
fresh process with an empty ``NUMBA_CACHE_DIR``) on 2-core AMD EPYC VMs: the least of a range on
a quiet VM, the most on one shared with four other jobs (load 5-10). A group shares most of its
code with the others (the lattice assembly, the linear algebra), so a second group costs less
once the first is compiled (``statics`` after ``states``: about 9 s of CPU); several groups are
quoted from the dearest alone to the sum of all (:func:`cpu_range`). Which commands run which
group:

* ``states``: ``states``, ``find_state`` (one design, serial kernels);
* ``statics``: every ``sweep``, ``solve_batch`` (parallel kernels);
* ``sensitivities``: ``find_state(..., sensitivities=True)``, ``lookup --refine``;
* ``snap``: ``snap``, ``snap_pressures``;
* ``dynamics``: ``simulate``;
* ``reset``: ``sweep`` with reset times, ``reset-maps``, batches; ``release``: the release model;
* ``unit-cell shell``: ``unitcell curve``, ``unit_cell_curve`` (the shell model of one dome);
* ``unit-cell contact``: ``two_unit_rest`` (the dome against its neighbour's wall).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

from numba.core import event as numba_event

from .._kernels._cache import is_cached
from .._kernels.dynamics import batch as dynamics_batch
from .._kernels.dynamics.ids import INTEGRATOR_RODAS4
from .._kernels.grasp import batch as grasp_batch
from .._kernels.grasp import equilibrium as grasp_equilibrium
from .._kernels.reset import reduced
from .._kernels.sensitivity import batch as sensitivity_batch
from .._kernels.shell import contact as shell_contact
from .._kernels.shell import path as shell_path
from .._kernels.snap import walk as ksnap
from .._kernels.statics import batch
from ..io.progress import Progress, active

__all__ = [
    "COMPILE_CPU_S",
    "COMPILE_MACHINE",
    "KERNEL_GROUPS",
    "CompileWatcher",
    "announce",
    "compile_notice",
    "cpu_range",
    "stop_watching",
    "uncompiled",
    "watch",
]

logger = logging.getLogger("dpfexplore.compile")

#: The entry kernels of each group (their callees are compiled with them).
KERNEL_GROUPS = {
    # one design runs the serial twins (a batch of a few rows is not worth the threads); the
    # node positions find_state adds (kstates.nodes_of) compile in under a second of CPU, and a
    # group must hold only what its announcer runs, or a process that never calls them would
    # announce a compilation on every start
    "states": (batch.solve_rows_serial,),
    "statics": (batch.solve_rows,),
    "dynamics": (dynamics_batch.INTEGRATORS[INTEGRATOR_RODAS4],),
    "reset": (dynamics_batch.RESET_TIMES_KERNELS[INTEGRATOR_RODAS4],),
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
#: Watchers registered with Numba (:func:`watch`); stopped ones are unregistered by the next.
_WATCHERS: list[CompileWatcher] = []
#: The machine :data:`COMPILE_CPU_S` was measured on (module docstring).
COMPILE_MACHINE = "a 2-core AMD EPYC VM"
#: First-compile cost of each group alone on an empty cache, seconds of CPU: (least, most) of
#: the runs on :data:`COMPILE_MACHINE` (``scripts/compile_cpu.py``): the least on a quiet VM,
#: the most on one shared with four other jobs (load 5-10), where CPU time is higher too.
COMPILE_CPU_S: dict[str, tuple[int, int]] = {
    "states": (19, 26),
    "statics": (22, 46),
    "sensitivities": (37, 60),
    "snap": (51, 72),
    "dynamics": (20, 49),
    "reset": (20, 56),
    "release": (20, 52),
    "unit-cell shell": (26, 27),
    "unit-cell contact": (7, 28),  # 7 once the shell is compiled (what unitcell runs first)
    # the lattice's compile plus the grasp's contact kernels (8 s), and its sorting kernel (7 s)
    "grasp": (31, 42),
    "grasp sort": (38, 49),
}


def uncompiled(groups: Iterable[str]) -> list[str]:
    """The groups among ``groups`` some of whose kernels have no cached machine code."""
    missing = []
    for group in groups:
        if any(is_cached(kernel) is False for kernel in KERNEL_GROUPS[group]):
            missing.append(group)
    return missing


def cpu_range(groups: Iterable[str]) -> str:
    """What compiling ``groups`` costs: ``"about 19-26 s of CPU on a 2-core AMD EPYC VM"``.

    For several groups, from the least of the dearest group alone to the sum of the most: the
    groups share code, so the second costs less once the first is compiled (``statics`` after
    ``states``: about 9 s of CPU instead of 45).
    """
    groups = list(groups)
    low = max(COMPILE_CPU_S[group][0] for group in groups)
    high = sum(COMPILE_CPU_S[group][1] for group in groups)
    return f"about {low}-{high} s of CPU on {COMPILE_MACHINE}"


def compile_notice(
    groups: Iterable[str], *, display: Progress | None = None, stages: bool = True
) -> str | None:
    """One line announcing a first compilation of ``groups``, or None if all are cached.

    Groups named here count as announced for the rest of the process (:func:`announce` stays
    quiet about them), so the CLI's notice and the API's log line never both appear. With
    ``stages`` (the commands), a notice starts the watcher that shows each group's compilation
    as a stage of ``display`` (default: the display open, else one on standard error;
    :func:`watch`); the API's log line (:func:`announce`) is its only output.
    """
    groups = [g for g in groups if g not in _SETTLED]
    missing = uncompiled(groups)
    _SETTLED.update(groups)
    if not missing:
        return None
    if stages:
        watch(missing, display=display)
    names = " and ".join(missing)
    return (
        f"compiling the {names} kernels for this machine (first run only: {cpu_range(missing)}, "
        f"longer in wall time on a busy machine; later runs load them from the Numba cache)"
    )


def announce(groups: Iterable[str]) -> None:
    """Log a first compilation of ``groups`` once per process (WARNING, ``dpfexplore.compile``).

    Cheap after the first call of a group in a process: a set lookup, no cache inspection.
    """
    pending = [g for g in groups if g not in _SETTLED]
    if not pending:
        return
    notice = compile_notice(pending, stages=False)
    if notice is not None:
        logger.warning("%s ...", notice)


def watch(groups: Iterable[str], *, display: Progress | None = None) -> CompileWatcher:
    """Show the compilation of ``groups`` as stages of the progress display, as Numba compiles.

    The display is ``display``, else the one the command has open
    (:func:`dpfexplore.io.progress.active`), else one of its own on standard error. The
    watcher listens to Numba's ``numba:compile`` events
    (fired only when Numba really compiles, not when it loads from its cache) and stops once
    every group's entry kernels are in memory.
    """
    _unregister([w for w in _WATCHERS if w.stopped])
    watcher = CompileWatcher(list(groups), display)
    numba_event.register("numba:compile", watcher)
    _WATCHERS.append(watcher)
    return watcher


def stop_watching() -> None:
    """Stop every compilation watcher of this process (never from inside a Numba event)."""
    for watcher in _WATCHERS:
        watcher.stop()
    _unregister(list(_WATCHERS))


def _unregister(watchers: list[CompileWatcher]) -> None:
    # not from an event: Numba iterates over its listeners while it calls them
    for watcher in watchers:
        numba_event.unregister("numba:compile", watcher)
        _WATCHERS.remove(watcher)


class CompileWatcher(numba_event.Listener):
    """A Numba event listener: each group's compilation a stage ``compiling the G kernels, ...``.

    Parameters
    ----------
    groups : list of str
        Names in :data:`KERNEL_GROUPS`, in the order the command compiles them.
    display : Progress, optional
        Where the stages go (:func:`watch`).
    """

    def __init__(self, groups: list[str], display: Progress | None = None) -> None:
        self.groups = groups
        self.depth = 0
        self.compiled: set = set()  # dispatchers whose outermost compilation ended
        self.current: int | None = None
        self.display = display
        self.own_display = False
        self.started = 0.0
        self.stopped = False

    def pending(self) -> int | None:
        """Index of the first group whose entry kernels are not all in memory, or None."""
        for index, group in enumerate(self.groups):
            if any(
                not kernel.overloads and kernel not in self.compiled
                for kernel in KERNEL_GROUPS[group]
            ):
                return index
        return None

    def compiling(self) -> bool:
        """Whether Numba has been compiling for a second or more (the heartbeat's question)."""
        return self.depth > 0 and time.monotonic() - self.started >= 1.0

    def on_start(self, event) -> None:
        """An outermost compilation begins: show the stage of the group it belongs to."""
        if self.stopped:
            return
        self.depth += 1
        if self.depth > 1:
            return
        self.started = time.monotonic()
        index = self.pending()
        if index is None:
            self.stop()
            return
        if index != self.current:
            self.current = index
            display = self._display()
            group = self.groups[index]
            display.stage(
                f"compiling the {group} kernels, group {index + 1}/{len(self.groups)} "
                f"({cpu_range([group])})",
                busy=self.compiling,
                cpu=True,
            )

    def on_end(self, event) -> None:
        """A compilation ended: after the outermost one, stop when every group is compiled.

        Numba adds the machine code to the dispatcher after this event, so the dispatcher
        whose compilation ended is remembered here.
        """
        if self.stopped:
            return
        self.depth = max(self.depth - 1, 0)
        if self.depth == 0:
            self.compiled.add(event.data.get("dispatcher") if event.data else None)
            if self.pending() is None:
                self.stop()

    def stop(self) -> None:
        """Stop listening; end the stage (and close a display of the watcher's own)."""
        self.stopped = True
        if self.display is not None:
            if self.own_display or not self.display.opened:
                self.display.close()  # nobody else ends it: its heartbeat stops here
            elif self.display.busy == self.compiling:
                self.display.end_stage()
            self.display = None

    def _display(self) -> Progress:
        if self.display is None:
            found = active()
            self.own_display = found is None
            self.display = Progress("dpfexplore") if found is None else found
        return self.display
