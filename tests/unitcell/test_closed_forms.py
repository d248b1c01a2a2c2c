"""The shell model against plate and shell theory (issue 21 §3, MODEL.md §11)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from dpfexplore.unitcell import apex_stiffness, unit_cell_curve
from dpfexplore.unitcell.checks import (
    bending_length,
    pinned_shallow_cap_stiffness,
    plate_stiffness,
    ridge_exponent,
    shallow_shell_stiffness,
)

E, NU = 26.0, 0.35


@pytest.mark.parametrize("t, r_b", [(0.5, 5.0), (1.0, 8.0)])
def test_pinned_plate_point_load_stiffness_within_one_percent(t, r_b):
    expected = plate_stiffness(E, NU, t, r_b)
    for H in (0.0, 1e-3 * t):  # the flat plate, and the limit H/t -> 0 of a cap
        k = apex_stiffness(H, t, r_b, E, NU, n_elements=64)
        assert abs(k / expected - 1.0) < 0.01


def _cap(ratio: float, R: float, t: float, n_per_length: int = 80) -> tuple[float, float, float]:
    """Shell model, finite pinned cap and Reissner stiffness at ``r_b = ratio ℓ`` (N/mm)."""
    r_b = ratio * bending_length(R, t, NU)
    H = R - math.sqrt(R * R - r_b * r_b)
    # grading 0.75 refines towards the apex: converged to ~1e-5 at 80 elements per ℓ
    k = apex_stiffness(H, t, r_b, E, NU, n_elements=int(n_per_length * ratio), grading=0.75)
    return k, pinned_shallow_cap_stiffness(E, NU, t, R, r_b), shallow_shell_stiffness(E, NU, t, R)


def _bvp_apex_deflection(x_b: float) -> float:
    """``w(0) 2 π D / (P ℓ²)`` of the pinned shallow cap, by collocation (no Kelvin functions).

    Unknowns over ``s = ln x`` (``x = r/ℓ``): ``w``, the slope ``θ``, ``m = ∇²w``, ``φ = Φ'``
    scaled by ``P R / (2 π ℓ)``, and ``n = ∇²Φ``; the point load enters as ``m' = 1/x - φ``.
    """

    def rhs(s, y):
        x = np.exp(s)
        _, theta, m, phi, n = y
        return x * np.vstack([theta, m - theta / x, 1.0 / x - phi, n - phi / x, theta])

    def edges(apex, edge):
        return np.array(
            [
                apex[1],  # θ = 0 at the apex
                apex[3],  # φ = r N_r = 0 at the apex
                edge[0],  # w = 0
                edge[2] - (1.0 - NU) * edge[1] / x_b,  # M_r = 0
                x_b * edge[4] - (1.0 + NU) * edge[3],  # u = 0
            ]
        )

    s = np.linspace(math.log(1e-9), math.log(x_b), 1000)
    solution = solve_bvp(rhs, edges, s, np.zeros((5, s.size)), tol=1e-9, max_nodes=500_000)
    assert solution.success, solution.message
    return float(solution.y[0, 0])


@pytest.mark.parametrize("ratio", [2.0, 8.0, 20.0])
def test_pinned_shallow_cap_closed_form_solves_the_boundary_value_problem(ratio):
    # R = 100, t = 0.1: the closed form against collocation of the same linear BVP (1e-12 seen)
    R, t = 100.0, 0.1
    D = E * t**3 / (12.0 * (1.0 - NU**2))
    ell = bending_length(R, t, NU)
    expected = 2.0 * math.pi * D / (ell**2 * _bvp_apex_deflection(ratio))
    k = pinned_shallow_cap_stiffness(E, NU, t, R, ratio * ell)
    assert abs(k / expected - 1.0) < 1e-8


def test_pinned_shallow_cap_limits():
    R, t = 100.0, 0.1
    ell = bending_length(R, t, NU)
    reissner = shallow_shell_stiffness(E, NU, t, R)
    # unbounded: the excess over Reissner tends to 4 (1 + ν) ℓ² / (π r_b²)
    for ratio in (200.0, 400.0):
        excess = pinned_shallow_cap_stiffness(E, NU, t, R, ratio * ell) / reissner - 1.0
        assert abs(excess * ratio**2 / (4.0 * (1.0 + NU) / math.pi) - 1.0) < 0.01
    # flat: R -> infinity at fixed r_b tends to the pinned plate, the excess going as R^-2
    # (as (r_b/ℓ)⁴: +5.8e-4 at R = 10⁴, +5.8e-8 at 10⁶ for r_b = 5, t = 0.1)
    r_b = 5.0
    excess = [
        pinned_shallow_cap_stiffness(E, NU, t, R_flat, r_b) / plate_stiffness(E, NU, t, r_b) - 1.0
        for R_flat in (1e4, 1e6)
    ]
    assert 0.0 < excess[1] < 1e-7 and 0.0 < excess[0] < 1e-3
    assert abs(excess[0] / excess[1] / 1e4 - 1.0) < 0.01
    assert pinned_shallow_cap_stiffness(E, NU, t, math.inf, r_b) == plate_stiffness(E, NU, t, r_b)


def test_shell_model_matches_the_finite_pinned_cap():
    # The shell model against the exact finite pinned cap of shallow-shell theory: -0.011 %,
    # -0.012 %, -0.016 % at r_b = 8, 10, 20 ℓ for R/t = 10⁴, and ten times that for R/t = 10³
    # (-0.108 %, -0.117 %, -0.155 %): the residual scales as t/R, the order of shallow-shell
    # theory itself.
    for ratio in (8.0, 10.0, 20.0):
        k, cap, _ = _cap(ratio, 100.0, 0.01)
        fine = k / cap - 1.0
        assert -2.5e-4 < fine < 0.0
        k, cap, _ = _cap(ratio, 100.0, 0.1)
        coarse = k / cap - 1.0
        assert -2e-3 < coarse < -0.8e-3
        assert 8.0 < coarse / fine < 12.0


def test_reissner_shallow_shell_stiffness_far_from_the_edge():
    # R/t = 1000. The shell model is +2.92 %, +1.79 %, +0.30 % above Reissner's unbounded shell
    # at r_b = 8, 10, 20 ℓ: the finite pinned cap's own excess (+3.03 %, +1.91 %, +0.45 %, exact
    # shallow-shell solution), less the t/R residual above. So "within 2 % at 8 ℓ" holds for no
    # pinned cap; the finite cap is within 2 % from r_b = 9.76 ℓ on (docs/guide/unitcell.md).
    errors = {}
    for ratio, model, finite in (
        (8.0, 0.0292, 0.0303),
        (10.0, 0.0179, 0.0191),
        (20.0, 0.0030, 0.0045),
    ):
        k, cap, reissner = _cap(ratio, 100.0, 0.1)
        errors[ratio] = k / reissner - 1.0
        assert abs(errors[ratio] - model) < 5e-4
        assert abs(cap / reissner - 1.0 - finite) < 5e-4
    assert 0.02 < errors[8.0] < 0.035
    assert 0.0 < errors[10.0] < 0.02
    assert 0.0 < errors[20.0] < 0.005
    reissner = shallow_shell_stiffness(E, NU, 0.1, 100.0)
    ell = bending_length(100.0, 0.1, NU)
    below, above = (pinned_shallow_cap_stiffness(E, NU, 0.1, 100.0, r * ell) for r in (9.75, 9.77))
    assert below / reissner > 1.02 > above / reissner


def test_pogorelov_ridge_exponent_of_a_thin_deep_cap():
    # R/t = 125: past ~20 thicknesses of travel the ridge regime F ~ sqrt(delta) sets in.
    run = unit_cell_curve(2.5, 0.05, 5.0, E, NU, n_elements=128, travel=3.0)
    exponent, points = ridge_exponent(run, 20.0, 50.0)
    assert points >= 10
    assert 0.5 <= exponent < 0.56
