"""The batch contract of ``reset_times_batch`` and the release model's error."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GRIPPER, PICKPLACE, reference_reset_times

from dpfexplore.model import status as st
from dpfexplore.model.design import MAX_UNITS, Design, DesignBatch
from dpfexplore.solvers.dynamics.release import release_reset_times
from dpfexplore.solvers.dynamics.simulate import PressureProfile, reset_times_batch, simulate

PULSE = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
SMALL = Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
ALL_LOW = Design(H=[2.9] * 5, U_L=6.0, U_sep=1.0, t=0.8, t_lim=1.0)


def _with_invalid_rows(designs):
    """A batch of ``designs`` plus one N = 0 row and one row with a negative height."""
    batch = DesignBatch.from_designs(designs)
    n = len(batch)
    fields = {name: getattr(batch, name) for name in DesignBatch.ARRAY_FIELDS}
    extra = {}
    for name, value in fields.items():
        value = np.asarray(value)
        extra[name] = np.concatenate([value, value[:2]])
    extra["n_units"][n] = 0
    extra["H"] = extra["H"].copy()
    extra["H"][n + 1, 0] = -1.0
    return DesignBatch(**extra)


@pytest.fixture(scope="module")
def batch_run():
    batch = _with_invalid_rows([Design(**PICKPLACE), Design(**GRIPPER), SMALL, ALL_LOW])
    return batch, reset_times_batch(batch, PULSE, t_end=15.0)


def test_contract_shapes_dtypes_and_invalid_rows(batch_run):
    batch, out = batch_run
    n = len(batch)
    assert set(out) == {
        "status",
        "final_state",
        "reset_time",
        "snap_through",
        "snap_back",
        "unit_class",
    }
    assert out["status"].dtype == np.int8 and out["status"].shape == (n,)
    assert out["final_state"].dtype == np.int64 and out["final_state"].shape == (n,)
    assert out["unit_class"].dtype == np.int8 and out["unit_class"].shape == (n, MAX_UNITS)
    for key in ("reset_time", "snap_through", "snap_back"):
        assert out[key].dtype == np.float64 and out[key].shape == (n, MAX_UNITS)
    np.testing.assert_array_equal(out["status"], [0, 0, 0, 0, st.INVALID_INPUT, st.INVALID_INPUT])
    for i in (4, 5):
        assert np.all(np.isnan(out["reset_time"][i])) and np.all(out["unit_class"][i] == -1)
        assert out["final_state"][i] == -1
    # padding beyond each design's N
    for i, n_units in enumerate(batch.n_units[:4]):
        assert np.all(np.isnan(out["reset_time"][i, n_units:]))
        assert np.all(np.isnan(out["snap_through"][i, n_units:]))
        assert np.all(out["unit_class"][i, n_units:] == -1)


def test_batch_rows_equal_single_simulations(batch_run):
    """The batch is the same computation as ``simulate`` (stopped once every unit reset)."""
    batch, out = batch_run
    for i in range(4):
        design = batch.design(i)
        single = simulate(design, PULSE, t_end=15.0, n_samples=0, stop_when_reset=True)
        n = design.n_units
        np.testing.assert_array_equal(out["reset_time"][i, :n], single.reset_time)
        np.testing.assert_array_equal(out["snap_through"][i, :n], single.snap_through)
        assert format(out["final_state"][i], f"0{n}b") == single.final_state
        names = {0: "bistable", 1: "metastable", 2: "monostable", -1: None}
        assert tuple(names[c] for c in out["unit_class"][i, :n]) == single.unit_class


def test_known_rows(batch_run):
    _, out = batch_run
    assert out["final_state"][0] == 0b111100
    # the reference integration's reset times (SciPy Radau, tests/data/reference)
    np.testing.assert_allclose(out["reset_time"][0, 4:6], reference_reset_times(), rtol=1e-3)
    assert out["final_state"][1] == 0b11110 and out["unit_class"][1, 4] == 1
    assert out["final_state"][3] == 0  # every unit of the all-low finger resets
    assert np.all(out["unit_class"][3, :5] == 1)


def test_empty_batch_and_bad_method():
    empty = DesignBatch.from_designs([SMALL]).take(np.array([], dtype=int))
    out = reset_times_batch(empty, PULSE, t_end=15.0)
    assert out["reset_time"].shape == (0, MAX_UNITS)
    with pytest.raises(ValueError, match="method"):
        reset_times_batch(DesignBatch.from_designs([SMALL]), PULSE, t_end=15.0, method="radau")


def test_overdamped_batch_agrees_with_full(batch_run):
    batch, out = batch_run
    od = reset_times_batch(batch.take(np.arange(4)), PULSE, t_end=15.0, method="rodas4-overdamped")
    np.testing.assert_array_equal(od["final_state"], out["final_state"][:4])
    finite = np.isfinite(out["reset_time"][:4])
    np.testing.assert_allclose(
        od["reset_time"][:4][finite], out["reset_time"][:4][finite], rtol=2e-3
    )


def test_release_model_error_within_its_claim():
    """Loose loading + Newton to the end of the hold + release: within 0.2 % of the full model.

    The claim (module docstring of :mod:`dpfexplore.solvers.dynamics.release`) rests on long holds;
    these designs hold 4 s against relaxation rates of 1.2 /s and faster. The all-low finger is the
    hard case: its units reset in a cascade and one is pushed back through by its neighbours.
    """
    designs = [
        Design(**PICKPLACE),
        Design(**GRIPPER),
        SMALL,
        ALL_LOW,
        Design(H=[4.5, 2.8, 3.0], U_L=8.0, U_sep=1.5, t=0.85, t_lim=1.5),
    ]
    batch = DesignBatch.from_designs(designs)
    full = reset_times_batch(batch, PULSE, t_end=15.0, atol=1e-6)
    rel = reset_times_batch(batch, PULSE, t_end=15.0, method="release", atol=1e-4)
    np.testing.assert_array_equal(rel["status"], 0)
    np.testing.assert_array_equal(rel["final_state"], full["final_state"])
    np.testing.assert_array_equal(rel["unit_class"], full["unit_class"])
    finite = np.isfinite(full["reset_time"])
    assert np.array_equal(finite, np.isfinite(rel["reset_time"]))
    err = np.abs(rel["reset_time"][finite] / full["reset_time"][finite] - 1.0)
    assert err.max() < 2e-3
    # snap-through times from the loose loading phase
    seen = np.isfinite(full["snap_through"])
    np.testing.assert_allclose(rel["snap_through"][seen], full["snap_through"][seen], atol=5e-3)
    single = release_reset_times(SMALL, PULSE, t_end=15.0, atol=1e-4)
    np.testing.assert_array_equal(single["reset_time"], rel["reset_time"][2, :2])
    with pytest.raises(ValueError, match="one pulse"):
        release_reset_times(
            SMALL, PressureProfile.pulses([(0.7, 0, 1, 2, 3), (0.7, 4, 5, 6, 7)]), t_end=15.0
        )


@pytest.mark.parametrize("method", ["rodas4", "rodas4-overdamped", "fast"])
def test_early_stop_waits_for_a_unit_pushed_back_over_its_threshold(method):
    """A designed walker purple zone: unit 2 crosses down just before unit 1 snaps back, is
    pushed back over its threshold and resets ~1 s later. A run stopped at the first moment
    both units are down reports the first crossing; the batch must equal the full-horizon run.
    """
    design = Design(H=[2.6044, 2.4733], U_L=6.5, U_sep=1.0, t=0.65, t_lim=1.0, E=26.0)
    profile = PressureProfile.pulse(0.2, [0.0, 0.1, 1.1, 1.2])
    full = simulate(design, profile, t_end=6.0)
    down_up_down = [int(sign) for _, unit, sign in full.events if unit == 2]
    assert down_up_down[-3:] == [-1, 1, -1]  # the hard case is still what it was built to be
    batch = reset_times_batch(DesignBatch.from_designs([design]), profile, t_end=6.0, method=method)
    np.testing.assert_allclose(batch["reset_time"][0, :2], full.reset_time, rtol=2e-3)


def test_a_failed_release_row_reports_its_loading_not_uninitialised_memory():
    """The gripper under a 0.7 MPa pulse: the release model does not converge (NOT_CONVERGED);
    its row reports what the loading recorded, the same on every call."""
    batch = DesignBatch.from_designs([Design(**GRIPPER), Design(**PICKPLACE)])
    pulse = PressureProfile.pulse(0.7, (0.0, 0.1, 0.2, 0.3))
    runs = [reset_times_batch(batch, pulse, t_end=2.0, method="release") for _ in range(2)]
    out = runs[0]
    assert out["status"][0] == st.NOT_CONVERGED
    n = len(GRIPPER["H"])
    for key in ("snap_through", "snap_back", "reset_time"):
        np.testing.assert_array_equal(out[key][0], runs[1][key][0])  # nothing left unwritten
        times = out[key][0, :n]
        # a time of the loading (0 to τ3 = 0.2 s) or NaN: no denormal left from np.empty
        assert np.all(np.isnan(times) | ((times > 1e-6) & (times <= 0.2))), (key, times)
    # units 1, 2 and 5 snapped through during the loading, 3 and 4 did not
    assert out["final_state"][0] == 0b11001
    assert np.isnan(out["snap_through"][0, 2:4]).all()
    assert np.isfinite(out["snap_through"][0, [0, 1, 4]]).all()
    # the pick-and-place finger fails the same way: no reset time, no class, from an unfinished
    # run (uninitialised memory had given it three metastable units resetting after up to 56 s)
    assert out["status"][1] == st.NOT_CONVERGED
    assert np.isnan(out["reset_time"][1]).all() and (out["unit_class"][1] == -1).all()
    through = out["snap_through"][1, : len(PICKPLACE["H"])]
    assert np.all(np.isnan(through) | ((through > 1e-6) & (through <= 0.2))), through
    assert np.all(np.isnan(out["reset_time"][0, :n]))  # the run did not finish: no reset times
