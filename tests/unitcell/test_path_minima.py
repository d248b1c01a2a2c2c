"""The ghost and the stepped-over rest on force curves whose minima are known in closed form.

The step's cubic Hermite interpolant is exact for a quadratic force, so both are exact here.
"""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore.unitcell.path import PathSamples, find_ghost, find_stepped_over_rests


def _path(c: float, points: np.ndarray):
    # F = (δ - 2)² + c, F' = 2 (δ - 2): a least force c at δ = 2
    force = (points - 2.0) ** 2 + c
    stiffness = 2.0 * (points - 2.0)
    return PathSamples(
        points, force, stiffness, np.ones(points.size, bool), np.zeros(points.size, int)
    )


def test_the_ghost_is_the_least_force_between_points():
    points = np.array([0.0, 0.7, 1.3, 1.9, 2.35, 3.0])
    ghost = find_ghost(_path(0.25, points), beyond=1.0)
    assert ghost.displacement == pytest.approx(2.0, abs=1e-12)
    assert ghost.force == pytest.approx(0.25, abs=1e-12)
    assert find_stepped_over_rests(_path(0.25, points), beyond=1.0) == []


def test_no_ghost_before_the_flat_position_or_on_an_unstable_branch():
    path = _path(0.25, np.linspace(0.0, 3.0, 7))
    assert find_ghost(path, beyond=1.0) is not None and find_ghost(path, beyond=2.5) is None
    path.stable[3:5] = False
    assert find_ghost(path, beyond=1.0) is None
    path.branch[4:] = 1
    assert find_ghost(path._replace(stable=~path.stable), beyond=1.0) is None


def test_a_rest_stepped_over_is_the_upward_zero_within_the_step():
    # both points push back (F > 0) but the force dips to -0.01 between them: barrier at
    # 2 - 0.1, rest at 2 + 0.1
    points = np.array([0.0, 1.0, 1.8, 2.25, 3.0])
    path = _path(-0.01, points)
    assert np.all(path.force > 0.0)
    (rest,) = find_stepped_over_rests(path, beyond=1.0)
    assert rest == pytest.approx(2.1, abs=1e-12)
    assert find_ghost(path, beyond=1.0) is None
