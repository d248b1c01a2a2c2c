"""Compile the kernels the suite needs before its tests start, on every core, each file once.

On a fresh clone Numba's cache is empty and compiling is most of the suite's CPU. The test
session (``conftest.pytest_sessionstart``, in the process that starts the pytest-xdist workers)
runs :data:`PLAN` before any test: phase after phase, each phase's lanes in parallel processes
(``python tests/compile_ahead.py STEP ...``). The lanes of a phase share no uncompiled kernel,
so no two processes ever write the same cache file (several processes writing one at once is a
known source of crashes); what the lanes share was compiled by an earlier phase. The workers then
only load machine code. It computes nothing the tests check: each step is the smallest public call
that compiles its kernels with the argument types the package uses.

Kernels only a test calls directly (a few small ones, and the benchmarks' timing loops) are
compiled by the worker that calls them; :func:`serialise_cache_access` makes the cache safe for
them: one process at a time writes it, and nobody reads it while a process writes.
"""

from __future__ import annotations

import fcntl
import hashlib
import sys
import tempfile
from pathlib import Path

#: Phases of lanes of steps. Lanes of one phase run at once and must not share a kernel that
#: an earlier phase has not compiled (checked by compiling each lane alone on the cache the
#: earlier phases left, and comparing the cache files each wrote): the statics family and the
#: dynamics family both sit on "states" (the lattice); "snap" lands a snapped finger with the
#: dynamics family's integrator and loaded state; the shell shares nothing with them, and the
#: unit-cell contact builds on the shell. The benchmarks time their own loops over the statics,
#: the sensitivities and the closed forms. Lanes are balanced by their compile times on an empty
#: cache (2-core AMD EPYC, seconds of CPU): states 32 | shell 24 + contact 7; statics 9 +
#: sensitivities 16 + batch 12 + benchmarks 9 + grasp 15 (contact 8, sorting 7) | dynamics 21 +
#: reset 11 + release 16; snap 25 + batch 18 | fast reset 35.
PLAN: tuple[tuple[tuple[str, ...], ...], ...] = (
    (("states",), ("unit-cell shell", "unit-cell contact")),
    (
        ("statics", "sensitivities", "sensitivities batch", "benchmarks", "grasp"),
        ("dynamics", "reset", "release"),
    ),
    (("snap", "snap batch"), ("fast reset",)),
)


def _benchmarks() -> None:
    from dpfexplore.bench import identify, sensitivities, statics
    from dpfexplore.sweep.warmup import tiny_batch

    statics._per_design_times(tiny_batch(), 2, passes=1, repeats=1)
    sensitivities.bench_size(2, 2, 2, seed=0, passes=1, repeats=1)
    identify._table_build(12, 1, 0)


def _grasp() -> None:
    import numpy as np

    from dpfexplore import load_design
    from dpfexplore.examples import example_path
    from dpfexplore.grasping import GraspOptions, grasp, gripper_of
    from dpfexplore.grasping.sort import run_sort

    gripper = gripper_of(load_design(example_path("gripper")))
    grasp(gripper, 40.0, mu=0.5)
    # the sorting kernel alone: sort_objects also runs the dynamics (the tip's reset), whose
    # kernels the other lane of this phase compiles
    run_sort(
        gripper,
        np.array([40.0]),
        np.array([0.01]),
        mu=0.5,
        depth=gripper.default_depth(),
        threshold=gripper.threshold(0.1),
        tip_lasts=True,
        options=GraspOptions(),
    )


def _steps() -> dict:
    import numpy as np

    from dpfexplore import (
        DesignBatch,
        find_state,
        load_design,
        reset_times_batch,
        simulate,
        snap_pressures,
        snap_pressures_batch,
        solve_batch,
    )
    from dpfexplore.examples import example_path
    from dpfexplore.solvers.dynamics.fast_reset import compile_fast_reset
    from dpfexplore.solvers.dynamics.simulate import PressureProfile
    from dpfexplore.solvers.statics import warm_up
    from dpfexplore.sweep.warmup import tiny_batch
    from dpfexplore.unitcell.contact import two_unit_rest
    from dpfexplore.unitcell.shell import unit_cell_curve

    finger = load_design(example_path("gripper"))
    pulse = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
    batch = DesignBatch.from_designs([finger])
    many = tiny_batch().take(np.zeros(128, dtype=np.int64))  # past the serial twins' 64 rows
    return {
        "states": lambda: find_state(finger, "11110"),
        "statics": lambda: warm_up(tiny_batch()),
        "sensitivities": lambda: find_state(finger, "11110", sensitivities=True),
        "sensitivities batch": lambda: solve_batch(many, sensitivities=True),
        "snap": lambda: snap_pressures(finger, P_max=0.7),
        "snap batch": lambda: snap_pressures_batch(tiny_batch(), P_max=0.7),
        "dynamics": lambda: simulate(finger, pulse, t_end=6.0),
        "reset": lambda: reset_times_batch(batch, pulse, t_end=6.0),
        "release": lambda: reset_times_batch(batch, pulse, t_end=6.0, method="release"),
        "fast reset": compile_fast_reset,
        "benchmarks": _benchmarks,
        "grasp": _grasp,
        "unit-cell shell": lambda: unit_cell_curve(3.0, 0.8, max_steps=20),
        "unit-cell contact": lambda: two_unit_rest(3.0, 0.8, gap=1.5, n_elements=16),
    }


def serialise_cache_access() -> None:
    """Take an inter-process lock around this process's Numba cache writes (and reads).

    Numba saves a kernel by reading its index, adding the signature under the first free data
    file name, writing the index, then the data file. Two processes saving different signatures
    of one kernel at once can both pick ``.1.nbc``: the index then names one signature's machine
    code for the other, and loading it crashes. An exclusive lock (``flock``) around every save
    and a shared one around every load make each save whole before anyone reads it. The lock
    file is per checkout (its path hashed), in the temporary directory.
    """
    from numba.core import caching

    if getattr(caching.Cache.save_overload, "_dpfexplore_locked", False):
        return
    root = str(Path(__file__).resolve().parents[1]).encode()
    lock = (
        Path(tempfile.gettempdir()) / f"dpfexplore-numba-{hashlib.sha1(root).hexdigest()[:12]}.lock"
    )

    def locked(method, mode):
        def wrapper(self, *args):
            with open(lock, "a") as handle:  # closing it releases the lock
                fcntl.flock(handle, mode)
                return method(self, *args)

        wrapper._dpfexplore_locked = True
        return wrapper

    caching.Cache.save_overload = locked(caching.Cache.save_overload, fcntl.LOCK_EX)
    caching.Cache.load_overload = locked(caching.Cache.load_overload, fcntl.LOCK_SH)


def groups_missing() -> bool:
    """Whether any of the package's kernel groups lacks cached machine code."""
    from dpfexplore.solvers.compilation import KERNEL_GROUPS, uncompiled

    return bool(uncompiled(KERNEL_GROUPS))


def main(names: list[str]) -> int:
    serialise_cache_access()
    steps = _steps()
    for name in names:
        steps[name]()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
