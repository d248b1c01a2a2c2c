"""Seconds of CPU each kernel group takes to compile on an empty Numba cache.

Each group compiles in a fresh process of its own with ``NUMBA_CACHE_DIR`` set to a new empty
directory, so the figure is what a first run of a command that needs only that group costs. It is
CPU time of the process (``time.process_time()``, every thread), not wall time: on a machine that
other processes load, wall time says how busy the machine was, CPU time what compiling costs.
The import of the package is left out (timed before the first call).

Run from the repository root::

    .venv/bin/python scripts/compile_cpu.py                 # every group, once
    .venv/bin/python scripts/compile_cpu.py states snap -r 2

and copy the ranges into ``COMPILE_CPU_S`` (``dpfexplore/solvers/compilation.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

#: One call per group that compiles its kernels, as the package calls them.
_CALLS = {
    "states": "find_state(finger, '11110')",
    "statics": "solve_batch(tiny_batch().take(np.zeros(128, dtype=np.int64)))",
    "sensitivities": "find_state(finger, '11110', sensitivities=True)",
    "snap": "snap_pressures(finger, P_max=0.7)",
    "dynamics": "simulate(finger, pulse, t_end=6.0)",
    "reset": "reset_times_batch(batch, pulse, t_end=6.0)",
    "release": "reset_times_batch(batch, pulse, t_end=6.0, method='release')",
    "unit-cell shell": "unit_cell_curve(3.0, 0.8, max_steps=20)",
    "unit-cell contact": "two_unit_rest(3.0, 0.8, gap=1.5, n_elements=16)",
}

_CHILD = """
import json, time
import numpy as np
from dpfexplore import (DesignBatch, find_state, load_design, reset_times_batch, simulate,
                        snap_pressures, solve_batch)
from dpfexplore.examples import example_path
from dpfexplore.solvers.dynamics.simulate import PressureProfile
from dpfexplore.sweep.warmup import tiny_batch
from dpfexplore.unitcell.contact import two_unit_rest
from dpfexplore.unitcell.shell import unit_cell_curve
finger = load_design(example_path("gripper"))
pulse = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
batch = DesignBatch.from_designs([finger])
cpu, wall = time.process_time(), time.perf_counter()
{call}
print(json.dumps({{"cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall}}))
"""


def measure(group: str) -> dict:
    """CPU and wall seconds of one group's first compile, in a fresh process, empty cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        done = subprocess.run(
            [sys.executable, "-c", _CHILD.format(call=_CALLS[group])],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    """Measure the groups given (default: every group) and print their CPU seconds."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("groups", nargs="*", default=list(_CALLS), help="groups (default: all)")
    parser.add_argument("-r", "--repeat", type=int, default=1, help="runs per group")
    args = parser.parse_args()
    print(
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    for group in args.groups:
        for _ in range(args.repeat):
            result = measure(group)
            print(
                f"{group:18s} cpu {result['cpu_s']:6.1f} s  wall {result['wall_s']:6.1f} s  "
                f"load {os.getloadavg()[0]:.1f}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
