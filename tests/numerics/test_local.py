"""The one local refiner: stops at the goal, keeps the best point, stays in the box, counts."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore.numerics.local import (
    GOAL_MET,
    NO_START,
    STOPPED,
    Stage,
    least_squares_in_box,
)


class Recorder:
    """A residual ``A x - b`` (None where ``missing(x)``) that records every point it is given."""

    def __init__(self, A, b, missing=None) -> None:
        self.A, self.b = np.atleast_2d(np.asarray(A, float)), np.asarray(b, float)
        self.missing = missing
        self.points: list[np.ndarray] = []
        self.values: list[float] = []

    def fun(self, x):
        self.points.append(x.copy())
        if self.missing is not None and self.missing(x):
            self.values.append(np.inf)
            return None, "none"
        f = self.A @ x - self.b
        self.values.append(float(f @ f))
        return f, ("info", x.copy())

    def jac(self, x):
        return self.A


def test_stops_at_the_first_point_that_meets_the_goal():
    # Rosenbrock-like curved residual: several steps are needed to get within the goal.
    calls: list[float] = []

    def fun(x):
        f = np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]]) * 0.1
        calls.append(float(f @ f))
        return f, None

    def jac(x):
        return np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]]) * 0.1

    goal = 1e-6
    result = least_squares_in_box(fun, [0.1, 0.9], jac=jac, max_nfev=200, goal=goal)
    assert result.status == GOAL_MET and result.success
    assert result.objective <= goal
    # the last evaluation is the first one within the goal: nothing is solved after it
    assert calls[-1] <= goal and all(v > goal for v in calls[:-1])
    assert result.nfev == len(calls) > 2
    np.testing.assert_allclose(result.objective, result.fun @ result.fun)


def test_start_that_meets_the_goal_is_evaluated_once():
    rec = Recorder(np.eye(2), [0.3, 0.4])
    result = least_squares_in_box(rec.fun, [0.3, 0.4], jac=rec.jac, max_nfev=10, goal=1e-12)
    assert result.status == GOAL_MET and result.nfev == 1 and len(rec.points) == 1
    assert result.message == "the start meets the goal"


def test_the_best_point_is_kept_not_the_last_stage():
    # Stage 1 solves the problem; stage 2, from the start again, has one evaluation: SciPy's own
    # answer there is the start, the refiner's is stage 1's point.
    rec = Recorder(np.eye(2), [0.7, 0.2])
    stages = (Stage("trf", None, 5), Stage("dogbox", "exact", 1))
    result = least_squares_in_box(rec.fun, [0.1, 0.9], jac=rec.jac, max_nfev=20, stages=stages)
    assert result.status == STOPPED and result.success  # no goal: a finished run
    best = int(np.argmin(rec.values))
    np.testing.assert_array_equal(result.x, rec.points[best])
    assert result.objective == min(rec.values) < 1e-6 < rec.values[-1]
    assert result.info[0] == "info"
    np.testing.assert_array_equal(result.info[1], result.x)
    # stage 2 evaluated the start again (its first call), and that is the last point solved
    np.testing.assert_array_equal(rec.points[-1], [0.1, 0.9])
    assert result.message.startswith("trf: ") and "; dogbox: " in result.message


def test_every_point_stays_in_the_box_and_the_answer_sits_on_the_bound():
    # The unconstrained minimum (1.5, -0.5) lies outside [0, 1]²: the answer is the corner.
    rec = Recorder(np.eye(2), [1.5, -0.5])
    result = least_squares_in_box(rec.fun, [0.5, 0.5], jac=rec.jac, max_nfev=30, goal=1e-12)
    assert result.status == STOPPED and not result.success
    points = np.array(rec.points)
    assert points.min() >= 0.0 and points.max() <= 1.0
    np.testing.assert_allclose(result.x, [1.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(result.objective, 0.5, rtol=1e-5)


def test_the_start_is_clipped_to_the_box():
    rec = Recorder(np.eye(1), [0.5])
    result = least_squares_in_box(rec.fun, [3.0], jac=rec.jac, max_nfev=10, goal=1e-16)
    np.testing.assert_array_equal(rec.points[0], [1.0])
    assert result.status == GOAL_MET


def test_points_without_a_residual_are_stepped_around_and_counted():
    # The residual exists only for x <= 0.6; its zero (0.8) lies beyond: the refiner ends at the
    # edge of where it exists, reports the failed trials and never returns a missing point.
    rec = Recorder(np.eye(1), [0.8], missing=lambda x: x[0] > 0.6)
    result = least_squares_in_box(rec.fun, [0.1], jac=rec.jac, max_nfev=40, goal=1e-12)
    assert result.status == STOPPED
    assert result.failures == sum(np.isinf(rec.values)) > 0
    assert result.x[0] <= 0.6 and result.x[0] > 0.55
    assert result.nfev == len(rec.points) <= 40


def test_a_start_without_a_residual_ends_the_run():
    rec = Recorder(np.eye(2), [0.5, 0.5], missing=lambda x: True)
    result = least_squares_in_box(rec.fun, [0.2, 0.2], jac=rec.jac, max_nfev=10, goal=1e-6)
    assert result.status == NO_START and not result.success
    assert result.fun is None and result.objective == np.inf and result.info == "none"
    assert result.nfev == 1 and result.failures == 1
    np.testing.assert_array_equal(result.x, [0.2, 0.2])


def test_the_budget_counts_every_evaluation_the_start_included():
    calls = []

    def fun(x):
        calls.append(x.copy())
        return np.array([np.sin(5 * x[0]) + 2.0, x[1] - 0.3]), None

    def jac(x):
        return np.array([[5 * np.cos(5 * x[0]), 0.0], [0.0, 1.0]])

    for budget in (1, 2, 5):
        calls.clear()
        result = least_squares_in_box(fun, [0.0, 0.9], jac=jac, max_nfev=budget, goal=1e-9)
        assert result.nfev == len(calls) <= budget
    # with stages, the caps add up to no more than the total
    calls.clear()
    stages = (Stage("dogbox", "exact", 3), Stage("trf", "lsmr"))
    result = least_squares_in_box(fun, [0.0, 0.9], jac=jac, max_nfev=7, stages=stages, goal=1e-9)
    assert result.nfev == len(calls) <= 7


def test_no_free_variables():
    result = least_squares_in_box(
        lambda x: (np.array([1.0]), None), np.zeros(0), jac=None, max_nfev=5, goal=0.0
    )
    assert result.status == STOPPED and result.message == "no free variables"
    assert result.nfev == 1 and result.objective == 1.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_nfev": 0}, "max_nfev = 0"),
        ({"max_nfev": 5, "stages": (Stage("lm"),)}, "stage method = 'lm'"),
        ({"max_nfev": 5, "x0": [np.nan]}, "need one finite vector"),
    ],
)
def test_invalid_options_are_named(kwargs, match):
    x0 = kwargs.pop("x0", [0.5])
    with pytest.raises(ValueError, match=match):
        least_squares_in_box(lambda x: (x, None), x0, jac=lambda x: np.eye(1), **kwargs)
