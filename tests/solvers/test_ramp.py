"""Inversion pressures from slow ramps: the extrapolated value brackets the fold."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore import Design, DesignBatch, PressureProfile, simulate
from dpfexplore.solvers.dynamics.ramp import inversion_pressures, ramp_snap_pressures

PURPLE = Design(H=[3.0, 3.0], U_L=6.5, U_sep=1.0, t=0.8, t_lim=1.0)
ACTION = Design(H=[3.4, 4.5, 4.5, 4.5], U_L=6.5, U_sep=1.0, t=1.0, t_lim=1.0)


@pytest.fixture(scope="module")
def pressures():
    batch = DesignBatch.from_designs([PURPLE, ACTION])
    return inversion_pressures(batch), [
        ramp_snap_pressures(batch, duration=T) for T in (40.0, 160.0, 640.0)
    ]


def test_two_thirds_law_predicts_a_slower_ramp(pressures):
    extrapolated, (p40, p160, p640) = pressures
    # faster ramps overshoot more; the rule's prediction for a 640 s ramp is within 0.3 %
    assert np.all(p40[:, 0] > p160[:, 0]) and np.all(p160[:, 0] > p640[:, 0])
    predicted = extrapolated + (p160 - extrapolated) / 4.0 ** (2.0 / 3.0)
    np.testing.assert_allclose(predicted[:, 0], p640[:, 0], rtol=3e-3)
    assert np.all(extrapolated[:, 0] < p640[:, 0])
    assert np.isnan(extrapolated[1, 3])  # the tip unit of the action section stays flat below 1 MPa


@pytest.mark.parametrize("row, design", [(0, PURPLE), (1, ACTION)])
def test_holding_just_below_stays_flat_just_above_inverts(pressures, row, design):
    P = pressures[0][row, 0]
    for factor, inverts in ((0.99, False), (1.01, True)):
        hold = factor * P
        run = simulate(
            design,
            PressureProfile.parse(f"0:0, 10:{hold}, 100:{hold}, 100.1:0"),
            t_end=100.1,
            n_samples=0,
        )
        assert np.isfinite(run.snap_through[0]) == inverts, (factor, run.snap_through)


def test_bad_ramp():
    with pytest.raises(ValueError, match="duration"):
        ramp_snap_pressures(DesignBatch.from_designs([PURPLE]), duration=0.0)
