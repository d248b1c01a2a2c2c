"""Compile the kernel groups the suite needs late, in a second process, while the suite starts.

Run by ``conftest.pytest_sessionstart`` as ``python tests/compile_ahead.py`` when the Numba cache
lacks a group. Numba compiles on one core, so on a fresh clone the first tests would otherwise
spend minutes compiling one group after another; this process fills the on-disk cache with the
groups the early tests do not touch (the suite's own processes then load them), using the
second core. It computes nothing the tests check: each step is the smallest public call that
compiles its group with the argument types the package uses.
"""

from __future__ import annotations

import sys


def main() -> int:
    from dpfexplore import DesignBatch, load_design, reset_times_batch, simulate, snap_pressures
    from dpfexplore.examples import example_path
    from dpfexplore.solvers.compilation import uncompiled
    from dpfexplore.solvers.dynamics.simulate import PressureProfile
    from dpfexplore.unitcell.shell import unit_cell_curve

    finger = load_design(example_path("gripper"))
    pulse = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
    batch = DesignBatch.from_designs([finger])
    steps = {
        "snap": lambda: snap_pressures(finger, P_max=0.7),
        "dynamics": lambda: simulate(finger, pulse, t_end=6.0),
        "reset": lambda: reset_times_batch(batch, pulse, t_end=6.0),
        "release": lambda: reset_times_batch(batch, pulse, t_end=6.0, method="release"),
        "unit-cell shell": lambda: unit_cell_curve(3.0, 0.8, max_steps=20),
    }
    for group in uncompiled(steps):
        steps[group]()
    return 0


if __name__ == "__main__":
    sys.exit(main())
