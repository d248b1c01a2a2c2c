"""Shared fixtures: the reference designs and the reference data of the seed implementation."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, settings

from dpfexplore.model.design import Design

REFERENCE = Path(__file__).parent / "data" / "reference"

# Property tests draw the same examples on every run and every machine (derandomize: the draws
# follow from each test's source), so a run's verdict never rests on luck; examples found by
# random search are pinned in the tests with @example. No example database (a clone has none,
# and replaying one machine's failures would make runs differ). No deadline and no too_slow
# check: both time the machine, whose load is not the code's. Search at random with
# ``pytest --hypothesis-profile=explore`` (failures are then kept in .hypothesis/).
settings.register_profile(
    "deterministic",
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile("explore", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("deterministic")


def pytest_sessionstart(session):
    """Compile the kernels before any test, on every core (``compile_ahead.py``).

    Runs in the process that starts the pytest-xdist workers, before it starts them, so that the
    workers only load cached machine code; in a worker it only serialises the cache access of
    what a test compiles itself. A warm cache starts nothing; nor does
    ``DPFEXPLORE_NO_COMPILE_AHEAD=1`` (each test then compiles what it needs).
    """
    import compile_ahead

    compile_ahead.serialise_cache_access()
    if hasattr(session.config, "workerinput") or os.environ.get("DPFEXPLORE_NO_COMPILE_AHEAD"):
        return
    if not compile_ahead.groups_missing():
        return
    started = time.perf_counter()
    try:
        compile_ahead.compile_all(workers=2)
    except RuntimeError as error:
        raise pytest.UsageError(f"compiling the kernels failed: {error}") from None
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        seconds = time.perf_counter() - started
        reporter.write_line(f"compiled the kernels ahead in {seconds:.0f} s (two processes)")


#: The longest test files (about 10-36 s each on a quiet 2-core machine), run first: with
#: ``--dist loadfile`` the workers take whole files in collection order, so the long ones start
#: at once and the short ones even out the end instead of one long file running alone there.
LONGEST_FIRST = (
    "tests/cli/test_result_commands_killed.py",
    "tests/sweep/test_engines.py",
    "tests/inverse/test_inverse_design.py",
    "tests/test_docs.py",
    "tests/cli/test_streams.py",
    "tests/cli/test_json_output.py",
    "tests/sweep/test_sweep_kill.py",
    "tests/inverse/test_timing_scenes.py",
    "tests/solvers/test_fast_reset.py",
    "tests/cli/test_bench.py",
)


def pytest_collection_modifyitems(config, items):
    """Run :data:`LONGEST_FIRST` first, every file's tests still together and in their order."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


GRIPPER = dict(
    H=[3.8187, 4.1549, 4.5246, 4.8239, 2.5], U_L=8.5773, U_sep=1.8232, t=0.8326, t_lim=1.056, E=26.0
)
PICKPLACE = dict(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0, E=26.0)


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    return REFERENCE


@pytest.fixture(scope="session")
def gripper() -> Design:
    return Design(**GRIPPER)


@pytest.fixture(scope="session")
def pickplace() -> Design:
    return Design(**PICKPLACE)


def read_reference(name: str) -> pd.DataFrame:
    return pd.read_csv(REFERENCE / name)


def design_from_row(row) -> Design:
    """Design of a reference CSV row (columns H as space-separated string, U_L, U_sep, ...)."""
    return Design(
        H=[float(v) for v in str(row.H).split()],
        U_L=float(row.U_L),
        U_sep=float(row.U_sep),
        t=float(row.t),
        t_lim=float(row.t_lim),
        E=float(row.E),
    )


def free_coordinates(group: pd.DataFrame) -> np.ndarray:
    """Free coordinates (kernel order) of one reference sample (rows in D1, D2, L2, ... order)."""
    return np.ravel(np.column_stack([group.x.to_numpy(), group.y.to_numpy()]))


#: End of the release ramp (s) of pickplace_dynamics.csv (τ4 of its pulse).
REFERENCE_RELEASE_END = 5.1
#: Barrier of the pick-and-place finger's metastable units 5-6 (H = 3, t = 0.83: α ≈ 0.1131
#: >= 1/9, so the barrier is u = 3/4; MODEL.md §4 and §8).
REFERENCE_METASTABLE_BARRIER = 0.75


def reference_reset_times() -> np.ndarray:
    """Reset times (s) of units 5 and 6 of the pick-and-place finger in the reference run.

    From ``pickplace_dynamics.csv`` (SciPy Radau, rtol 1e-4): the time after ``τ4`` at which each
    extension falls back below its barrier, linearly interpolated between the 0.025 s samples
    (the interpolation is good to ~5e-4 s: use ``rtol >= 1e-3``).
    """
    frame = read_reference("pickplace_dynamics.csv")
    t = frame.t.to_numpy()
    times = []
    for unit in (5, 6):
        u = frame[f"ext{unit}"].to_numpy()
        after = np.flatnonzero((t > REFERENCE_RELEASE_END) & (u < REFERENCE_METASTABLE_BARRIER))
        i = after[0]
        frac = (REFERENCE_METASTABLE_BARRIER - u[i - 1]) / (u[i] - u[i - 1])
        times.append(t[i - 1] + frac * (t[i] - t[i - 1]) - REFERENCE_RELEASE_END)
    return np.array(times)


def spy(monkeypatch, module, name: str) -> list:
    """Wrap ``module.name`` so that each call's return value is appended to the returned list.

    The commands import their plotting functions when they plot, so a spy on the plotting
    module sees the Axes or Figure a command drew and saved.
    """
    calls: list = []
    original = getattr(module, name)

    def wrapper(*args, **kwargs):
        calls.append(original(*args, **kwargs))
        return calls[-1]

    monkeypatch.setattr(module, name, wrapper)
    return calls
