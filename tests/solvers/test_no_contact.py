"""Units whose reach d is clamped (MODEL.md §3) are classed no_contact wherever classes appear."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore import Design, DesignBatch, PressureProfile, reset_times_batch, simulate
from dpfexplore.solvers.dynamics.resetmaps import reset_time_maps
from dpfexplore.solvers.dynamics.simulate import CLASS_NAMES
from dpfexplore.sweep.evaluation import _dynamics_fields

PULSE = PressureProfile(P0=0.7, tau=(0.0, 1.0, 5.0, 5.1))


def raw_reach(H, t, U_sep=1.0, t_ch=1.0):
    """MODEL.md §3's closed form for d before the clamp, written out."""
    return (0.2565 * t + 2.1425 * H) - H - U_sep - t_ch / 2 - t / 2


def test_walker_purple_units_have_no_contact():
    # H = 1.1, t = 1.0: d = -0.487 mm, clamped to 0.01 mm; the dynamics used to call these
    # units metastable (reset 0.054 s) and monostable
    assert raw_reach(1.1, 1.0) < 0
    design = Design(H=[1.1, 1.1], U_L=6.5, U_sep=1.0, t=1.0, t_lim=1.0)
    run = simulate(design, PressureProfile(P0=0.4, tau=(0.0, 0.1, 1.1, 1.2)), t_end=5.0)
    assert run.unit_class == ("no_contact", "no_contact")
    assert np.all(np.isnan(run.reset_time)) and np.all(np.isnan(run.snap_through))
    assert run.final_state == "00"
    assert len(run.events) > 0  # the raw crossings of the µm-scale threshold stay in the log
    assert run.to_dict()["classes"] == ["no_contact", "no_contact"]


@pytest.fixture(scope="module")
def mixed():
    """A bistable base, a no-contact unit and a metastable tip; and the same finger without the
    no-contact unit's clamp (H = 2.0 there: d > 0)."""
    assert raw_reach(1.1, 0.83) < 0 < raw_reach(2.0, 0.83)
    with_clamp = Design(H=[4.0, 1.1, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    return with_clamp, simulate(with_clamp, PULSE, t_end=15.0)


def test_single_run_classes(mixed):
    _, run = mixed
    assert run.unit_class == ("bistable", "no_contact", "metastable")
    assert run.reset_time[0] == np.inf and np.isnan(run.reset_time[1])
    assert run.reset_time[2] > 0.05
    assert run.final_state == "100"


def test_batch_codes_match_single_runs(mixed):
    design, run = mixed
    plain = Design(H=[4.5, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    batch = DesignBatch.from_designs([design, plain])
    out = reset_times_batch(batch, PULSE, t_end=15.0)
    codes = {name: code for code, name in CLASS_NAMES.items()}
    assert out["unit_class"][0, :3].tolist() == [codes[c] for c in run.unit_class]
    assert out["unit_class"][0, 1] == 3 and CLASS_NAMES[3] == "no_contact"
    np.testing.assert_allclose(out["reset_time"][0, :3], run.reset_time, rtol=1e-12)
    assert out["final_state"][0] == 0b100
    assert 3 not in out["unit_class"][1]  # a finger with contact everywhere is unchanged
    assert out["unit_class"][1, :2].tolist() == [
        codes[c] for c in simulate(plain, PULSE, t_end=15.0).unit_class
    ]


def test_release_model_classes_too(mixed):
    design, _ = mixed
    out = reset_times_batch(DesignBatch.from_designs([design]), PULSE, t_end=15.0, method="release")
    assert out["unit_class"][0, :3].tolist() == [0, 3, 1]


def test_sweep_column_and_reset_maps_name_the_class():
    fields = {f.name: f for f in _dynamics_fields(2)}
    assert b"3 no contact" in fields["unit_class_1"].metadata[b"description"]
    maps = reset_time_maps(
        H_values=(1.1, 3.0),
        t_at_H=1.0,
        t_values=(0.8,),
        hold_values=(1.0,),
        hold_H=(1.1,),
        hold_t=1.0,
        t_after=2.0,
    )
    by_height = maps["H"].set_index("H")["unit_class"]
    assert by_height[1.1] == "no_contact" and by_height[3.0] != "no_contact"
    assert np.isnan(maps["H"].set_index("H")["reset_time"][1.1])
    assert set(maps["hold"]["unit_class"]) == {"no_contact"}
