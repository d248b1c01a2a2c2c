"""A small real sweep dataset for the explorer's tests: N = 2..4, every state of 100 designs."""

from __future__ import annotations

import numpy as np
import pytest
from sweep_helpers import make_job

from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage.store import read_results

#: Designs per N; every state: 100 * (4 + 8 + 16) = 2800 rows.
SAMPLES = 100


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A complete sweep directory of the solver's rows (stiffness, min eig, every state)."""
    out = tmp_path_factory.mktemp("explore") / "small"
    spec = make_job(
        **{
            "space.n_units": [2, 3, 4],
            "job.samples_per_n": SAMPLES,
            "compute.states": "all",
            "compute.min_eig": True,
        }
    )
    run_sweep(spec, out)
    return out


@pytest.fixture(scope="module")
def frame(dataset):
    """The dataset as pandas reads it through the store (the independent reference)."""
    return read_results(dataset)


def isolated_ok_row(frame, tip_scale: float) -> int:
    """A row with status ok whose tip is farther than ``tip_scale`` mm from every other tip."""
    tips = frame[["tip_x", "tip_y"]].to_numpy(float)
    finite = np.all(np.isfinite(tips), axis=1)
    best, best_gap = -1, 0.0
    for i in np.flatnonzero((frame["status"].to_numpy() == 0) & finite):
        d = np.hypot(*(tips[finite] - tips[i]).T)
        gap = np.partition(d, 1)[1]
        if gap > best_gap and 15 < tips[i, 0] < 55:
            best, best_gap = int(i), float(gap)
    assert best_gap > tip_scale, f"no tip isolated by {tip_scale} mm"
    return best
