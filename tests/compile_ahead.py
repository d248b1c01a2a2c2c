"""Compile the kernels the suite needs before its tests start, on every core, each file once.

On a fresh clone Numba's cache is empty and compiling is most of the suite's CPU. The test
session (``conftest.pytest_sessionstart``, in the process that starts the pytest-xdist workers)
runs every step of :data:`STEPS` before any test (:func:`compile_all`): two long-lived processes,
one per core, each taking the next step whose prerequisites are done, so that no two processes
ever write the same cache file (several processes writing one at once is a known source of
crashes). The workers then only load machine code. It computes nothing the tests check: each step
is the smallest public call that compiles its kernels with the argument types the package uses.

Kernels only a test calls directly (a few small ones, and the benchmarks' timing loops) are
compiled by the worker that calls them; :func:`serialise_cache_access` makes the cache safe for
them: one process at a time writes it, and nobody reads it while a process writes.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import selectors
import subprocess
import sys
import tempfile
from pathlib import Path

#: Each step: the steps that compile kernels it also calls, and its compile time on an empty cache
#: (seconds of CPU, 2-core AMD EPYC). A step starts once those steps are done, so no two processes
#: ever compile one kernel at once (several processes writing one cache file at once is a known
#: source of crashes): the prerequisites were found by running each step alone on a cache that
#: held only "states" and comparing the kernels each compiled. The statics, sensitivity and
#: dynamics families all sit on "states" (the lattice); reset times and the release run the
#: dynamics family's integrators and events; "snap" lands a snapped finger with those and the
#: release's loaded state; the shell and the explorer's map share nothing with them, and the
#: unit-cell contact builds on the shell. The benchmarks time their own loops over the statics,
#: the sensitivities and the closed forms; the grasp's contact and sorting kernels call the
#: lattice and its factorisations as the statics and the sensitivities do. The times order the
#: ready steps (the longest chain of steps still to run first).
STEPS: dict[str, tuple[tuple[str, ...], float]] = {
    "states": ((), 22),
    "unit-cell shell": ((), 24),
    "unit-cell contact": (("unit-cell shell",), 7),
    "statics": (("states",), 9),
    "sensitivities": (("states",), 16),
    "sensitivities batch": (("sensitivities",), 12),
    "benchmarks": (("statics", "sensitivities"), 12),
    "dynamics": (("states",), 16),
    "reset": (("dynamics",), 9),
    "release": (("dynamics",), 14),
    "snap": (("dynamics", "release"), 19),
    "snap batch": (("snap",), 20),
    "fast reset": (("release",), 27),
    "explore raster": ((), 1),
    "grasp": (("statics", "sensitivities"), 15),
}


def chain_lengths() -> dict[str, float]:
    """For each step, the compile time of the longest chain of steps that starts with it (s)."""
    after: dict[str, list[str]] = {name: [] for name in STEPS}
    for name, (before, _) in STEPS.items():
        for step in before:
            after[step].append(name)
    lengths: dict[str, float] = {}

    def length(name: str) -> float:
        if name not in lengths:
            lengths[name] = STEPS[name][1] + max((length(n) for n in after[name]), default=0.0)
        return lengths[name]

    for name in STEPS:
        length(name)
    return lengths


def compile_all(workers: int = 2) -> None:
    """Run every step of :data:`STEPS` in ``workers`` long-lived processes, as soon as it may.

    Each process (``python tests/compile_ahead.py --serve``) runs the steps it is handed one after
    another, keeping what it compiled in memory; a free process takes the ready step whose chain
    of later steps is longest (list scheduling), so both cores stay busy until the end.

    Raises
    ------
    RuntimeError
        A process ended before its step was done (its error is on stderr).
    """
    lanes = [
        subprocess.Popen(
            [sys.executable, __file__, "--serve"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        for _ in range(workers)
    ]
    chain = chain_lengths()
    pending, done, running = set(STEPS), set(), {}
    events = selectors.DefaultSelector()
    for lane in lanes:
        events.register(lane.stdout, selectors.EVENT_READ, lane)
    try:
        while pending or running:
            for lane in lanes:
                ready = sorted(
                    (s for s in pending if set(STEPS[s][0]) <= done), key=lambda s: -chain[s]
                )
                if lane in running or not ready:
                    continue
                pending.remove(ready[0])
                running[lane] = ready[0]
                lane.stdin.write(ready[0] + "\n")
                lane.stdin.flush()
            if not running:
                raise RuntimeError(f"steps whose prerequisites never run: {sorted(pending)}")
            for key, _ in events.select():
                lane = key.data
                if lane.stdout.readline().strip() != running[lane]:
                    raise RuntimeError(f"compiling {running[lane]!r} failed (exit {lane.wait()})")
                done.add(running.pop(lane))
    finally:
        for lane in lanes:
            if running:
                lane.kill()
            lane.stdin.close()  # the end of its input ends a lane
            lane.wait()
        events.close()


def serve() -> int:
    """Run the steps named on stdin, one per line; answer each with its name once it is done.

    The answers go out on the original stdout; whatever a step prints goes to stderr.
    """
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    serialise_cache_access()
    steps = _steps()
    for line in sys.stdin:
        steps[line.strip()]()
        answers.write(line)
        answers.flush()
    return 0


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
    # the sorting kernel alone: sort_objects also runs the dynamics (the tip's reset), which
    # the dynamics steps compile
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
        "explore raster": _explore_raster,
    }


def _explore_raster() -> None:
    import numpy as np

    from dpfexplore.explore.raster import rasterize

    tip = np.zeros((4, 2))
    rasterize(tip, (-1.0, 1.0), (-1.0, 1.0), 4, 4, categories=np.zeros(4, dtype=np.int64))
    rasterize(tip, (-1.0, 1.0), (-1.0, 1.0), 4, 4, values=np.zeros(4))


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
    """``--serve``: :func:`serve`; otherwise run the named steps in this process."""
    if names == ["--serve"]:
        return serve()
    serialise_cache_access()
    steps = _steps()
    for name in names:
        steps[name]()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
