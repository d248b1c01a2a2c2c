"""Closed-form constants and the isolated-dome analysis (MODEL.md §3-§4)."""

from __future__ import annotations

import numpy as np
import pytest
from model_helpers import height_for_alpha

from dpfexplore.model.constants import (
    ALPHA_BISTABLE,
    NO_CONTACT_REACH,
    analyse_domes,
    dome_alpha,
    dome_energy,
    dome_force,
    dome_radius,
    dome_reach,
    dome_stiffness,
)
from dpfexplore.model.design import Design
from dpfexplore.solvers.lattice import spring_constants


@pytest.mark.parametrize("offset", [-1e-6, 1e-6])
def test_alpha_within_1e6_of_the_saddle_node_on_both_sides(offset):
    t = 0.83
    H = height_for_alpha(ALPHA_BISTABLE + offset, t)
    R = dome_radius(H, 5.0)
    alpha = float(dome_alpha(H, t, R))
    assert alpha == pytest.approx(ALPHA_BISTABLE + offset, abs=1e-13)
    k_b = float(dome_stiffness(26.0, H, t, R))
    d = 1.7
    a = analyse_domes(k_b, alpha, d)
    if offset < 0:
        assert a.regime == "bistable"
        # barrier and second minimum are the zeros of the force, a maximum and a minimum
        for u, curvature_sign in ((a.u_barrier, -1), (a.u_second_min, 1)):
            assert dome_force(u * d, k_b, alpha, d) == pytest.approx(0.0, abs=1e-12 * k_b * d)
            eps = 1e-4
            second = dome_force((u + eps) * d, k_b, alpha, d) - dome_force(
                (u - eps) * d, k_b, alpha, d
            )
            assert np.sign(second) == curvature_sign
        # they merge at 3/4 like the square root of the distance to the bifurcation
        gap = a.u_second_min - a.u_barrier
        assert gap == pytest.approx(0.5 * np.sqrt((1 - 9 * alpha) / (1 - alpha)), rel=1e-12)
        assert 0.0 < gap < 2e-3
        assert a.u_inversion == a.u_barrier
    else:
        assert a.regime == "metastable"
        assert np.isnan(a.u_barrier) and np.isnan(a.u_second_min)
        assert a.u_inversion == 0.75
        # no second zero of the force: it stays positive past the ghost
        u = np.linspace(0.01, 2.0, 20001)
        assert np.all(dome_force(u * d, k_b, alpha, d) > 0)


def test_inverted_energy_and_peak_force_closed_forms():
    k_b, alpha, d = 14.2, 0.058, 2.87
    assert dome_energy(d, k_b, alpha, d) == pytest.approx(0.5 * k_b * d * d * alpha, rel=1e-14)
    a = analyse_domes(k_b, alpha, d)
    u = np.linspace(0.0, a.u_barrier, 200001)
    force = dome_force(u * d, k_b, alpha, d)
    assert a.peak_force == pytest.approx(force.max(), rel=1e-9)
    assert a.peak_u == pytest.approx(u[force.argmax()], abs=1e-5)
    assert a.barrier_energy == pytest.approx(dome_energy(a.u_barrier * d, k_b, alpha, d))


def test_regimes_over_alpha():
    a = analyse_domes(10.0, np.array([0.05, 1 / 9, 0.2, 1 / 3, 0.5]), 2.0)
    assert list(a.regime) == ["bistable", "metastable", "metastable", "monostable", "monostable"]
    assert np.isnan(a.peak_force[3:]).all() and np.all(a.peak_force[:3] > 0)


def test_reach_is_clamped_and_flagged_when_the_dome_cannot_touch():
    d, no_contact = dome_reach(np.array([4.0, 3.0]), 0.8, np.array([1.0, 4.0]), 1.0)
    assert not no_contact[0] and d[0] == pytest.approx(
        0.2565 * 0.8 + 1.1425 * 4.0 - 1.0 - 0.5 - 0.4
    )
    assert no_contact[1] and d[1] == NO_CONTACT_REACH
    c = spring_constants(Design(H=[4.0, 3.0], U_L=6.0, U_sep=[1.0, 4.0], t=0.8, t_lim=1.0))
    assert list(c.no_contact) == [False, True]


def test_stiffnesses_are_proportional_to_E_and_alpha_is_not():
    one = spring_constants(Design(H=[3.5, 4.5], U_L=7.0, U_sep=2.0, t=0.7, t_lim=1.3, E=10.0))
    three = spring_constants(Design(H=[3.5, 4.5], U_L=7.0, U_sep=2.0, t=0.7, t_lim=1.3, E=30.0))
    for name in ("k_b", "k_lim", "k_post", "k_t"):
        np.testing.assert_allclose(getattr(three, name), 3 * getattr(one, name), rtol=1e-14)
    np.testing.assert_array_equal(three.alpha, one.alpha)
    np.testing.assert_array_equal(three.d, one.d)
    np.testing.assert_allclose(one.k_post, 5 * one.k_lim)
    # implementation's denominators: U_L + t + t_ch and U_sep + t + t_ch
    assert one.k_lim[0] == pytest.approx(10.0 * 1.3 * 15.0 / (7.0 + 0.7 + 1.0))
    assert one.k_t[0] == pytest.approx(
        10.0 * 1.3**3 / (12 * (1 - 0.35**2)) * 15.0 / (2.0 + 0.7 + 1.0)
    )
