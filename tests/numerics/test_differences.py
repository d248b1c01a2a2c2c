"""The package's one central-difference routine, against closed-form derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore.numerics.differences import central_differences


def f(X):
    X = np.atleast_2d(X)
    return np.column_stack([np.sin(X[:, 0]) * X[:, 1], np.exp(0.5 * X[:, 1]) + X[:, 0] ** 3])


def exact(x):
    return np.array(
        [
            [np.cos(x[0]) * x[1], np.sin(x[0])],
            [3 * x[0] ** 2, 0.5 * np.exp(0.5 * x[1])],
        ]
    )


def test_matches_closed_form_and_richardson_is_more_accurate():
    x = np.array([0.7, 1.3])
    plain = central_differences(f, x, f(x)[0], step=1e-3)
    better = central_differences(f, x, f(x)[0], step=1e-3, richardson=True)
    np.testing.assert_allclose(plain, exact(x), rtol=1e-5)
    assert np.abs(better - exact(x)).max() < 0.01 * np.abs(plain - exact(x)).max()


def test_bounds_clip_the_stencil_and_missing_sides_fall_back():
    x = np.array([1.0, 0.5])
    seen = []

    def g(X):
        seen.append(X.copy())
        return f(X)

    jac = central_differences(g, x, f(x)[0], step=1e-4, lower=0.0, upper=1.0)
    assert np.all(seen[0] <= 1.0)  # x[0] sits on the upper bound: one-sided there
    np.testing.assert_allclose(jac, exact(x), rtol=1e-3)

    def missing_up(X):
        values = f(X)
        values[X[:, 0] > x[0]] = np.nan  # the state collapses on one side
        return values

    jac = central_differences(missing_up, x, f(x)[0], step=1e-6)
    np.testing.assert_allclose(jac[:, 0], exact(x)[:, 0], rtol=1e-4)

    def missing_both(X):
        values = f(X)
        values[X[:, 1] != x[1]] = np.nan
        return values

    jac = central_differences(missing_both, x, f(x)[0], step=1e-6)
    assert np.all(jac[:, 1] == 0.0)  # no side: the caller cannot move along it


def test_only_the_asked_columns():
    x = np.array([0.2, 0.4])
    calls = []

    def g(X):
        calls.append(len(X))
        return f(X)

    jac = central_differences(g, x, f(x)[0], step=1e-4, columns=[1])
    assert calls == [2] and np.all(jac[:, 0] == 0.0)
    assert jac[:, 1] == pytest.approx(exact(x)[:, 1], rel=1e-6)
