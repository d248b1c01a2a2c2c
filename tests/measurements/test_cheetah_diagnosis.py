"""Why shell-extended loses cheetah-target-5's unit 1 (docs/guide/validation.md, "Why").

The claim: a dome of the law pushing against a linear spring ``K`` stays inverted iff
``K <= k_b (1 - 9 alpha) / 8`` (its reach drops out); unit 1 pushes against ``k_t / h²``; the
shell set's ``k_b`` and ``alpha`` together (not its ``tip_ratio``) take unit 1 of
cheetah-target-5 past that limit, and the exact model agrees.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dpfexplore import find_state
from dpfexplore.measurements import packaged_measurements, read_measurements
from dpfexplore.model.constants_set import DEFAULT, find_constants_set
from dpfexplore.solvers.lattice import spring_constants

FORMS = ("k_hat", "alpha", "tip_ratio")


@pytest.fixture(scope="module")
def finger():
    (target,) = [
        f
        for f in read_measurements(packaged_measurements()[0]).fingers
        if f.name == "cheetah-target-5"
    ]
    return target


def _mixed(from_shell):
    shell = find_constants_set("shell-extended")
    forms = {f: getattr(shell if f in from_shell else DEFAULT, f) for f in FORMS}
    return dataclasses.replace(DEFAULT, name="mix:" + ",".join(from_shell), **forms)


@pytest.mark.parametrize("alpha", [0.0, 0.05, 0.1])
def test_holding_capacity_is_the_largest_spring_an_inverted_dome_resists(alpha):
    """Law force plus K x has a root past the barrier iff K <= k_b (1 - 9 alpha) / 8, any d."""
    k_b, d = 3.0, 2.7
    capacity = k_b * (1 - 9 * alpha) / 8
    x = np.linspace(0.3 * d, 1.2 * d, 200_001)
    u = x / d
    for K, holds in ((0.99 * capacity, True), (1.01 * capacity, False)):
        total = k_b * x * (1 + (1 - alpha) * (2 * u * u - 3 * u)) + K * x  # dome + spring
        assert bool(np.any(total <= 0)) is holds


def test_shell_kb_and_alpha_not_tip_ratio_release_unit_1(finger):
    found = {
        forms: find_state(finger.design.replace(constants=_mixed(forms)), finger.state).found
        for forms in [(), ("tip_ratio",), ("k_hat",), ("alpha",), ("k_hat", "alpha"), FORMS]
    }
    assert found[()] == found[("tip_ratio",)] == found[("k_hat",)] == found[("alpha",)] == "11111"
    assert found[("k_hat", "alpha")] == found[FORMS] == "01111"
    # the hold number of unit 1 (frame k_t / h² over the dome's capacity) says the same
    for forms, held in (((), True), (("k_hat", "alpha"), False)):
        c = spring_constants(finger.design.replace(constants=_mixed(forms)))
        q = (c.k_t[0] / c.h**2) / (c.k_b[0] * (1 - 9 * c.alpha[0]) / 8)
        assert bool(q < 1) is held
        assert 0.5 < q < 1.3  # paper 0.61, shell 1.23: neither is a near call
