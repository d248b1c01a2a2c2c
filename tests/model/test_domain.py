"""The physical domain (rejected outside), the fitted range (flagged), and the collapsed-row
invariant over the accepted domain."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import GRIPPER
from hypothesis import example, given, settings
from hypothesis import strategies as hs

from dpfexplore.cli import main
from dpfexplore.model import status as st
from dpfexplore.model.design import Design, DesignBatch
from dpfexplore.model.domain import FITTED_RANGES, MAX_UNITS
from dpfexplore.solvers.statics import solve_batch

TALL = dict(H=[50.0, 50.0, 50.0], U_L=8.0, U_sep=1.0, t=0.8, t_lim=1.0)


def batch_of(rows: list[dict]) -> DesignBatch:
    """A batch built from raw arrays (no Design validation on the way)."""
    n = len(rows)
    per_unit = {name: np.full((n, MAX_UNITS), np.nan) for name in ("H", "U_L", "U_sep")}
    for i, row in enumerate(rows):
        k = len(row["H"])
        for name in per_unit:
            per_unit[name][i, :k] = row[name]
    return DesignBatch(
        n_units=np.array([len(r["H"]) for r in rows]),
        **per_unit,
        **{
            name: np.array([float(r.get(name, d)) for r in rows])
            for name, d in (
                ("t", 0.8),
                ("t_lim", 1.0),
                ("E", 26.0),
                ("nu", 0.35),
                ("r_b", 5.0),
                ("t_ch", 1.0),
            )
        },
    )


def test_a_dome_taller_than_its_base_radius_is_rejected_naming_the_field():
    with pytest.raises(ValueError, match=r"^H\[unit 1\] = 50\.0 mm: taller than the dome base"):
        Design(**TALL)
    # the hemisphere itself is a dome
    assert Design(H=[5.0], U_L=8.0, U_sep=1.0, t=0.8, t_lim=1.0).n_units == 1
    with pytest.raises(ValueError, match=r"H\[unit 2\] = 5\.5 mm"):
        Design(H=[4.0, 5.5], U_L=8.0, U_sep=1.0, t=0.8, t_lim=1.0)


def test_a_dome_not_shorter_than_its_unit_is_rejected():
    with pytest.raises(
        ValueError,
        match=r"H\[unit 2\] = 4\.5 mm: not shorter than its unit, "
        r"U_L\[unit 2\] = 4\.5 mm",
    ):
        Design(H=[4.0, 4.5], U_L=[6.0, 4.5], U_sep=1.0, t=0.8, t_lim=1.0)


def test_a_batch_gives_outside_domain_rows_and_solves_nothing_for_them():
    inside = dict(H=[4.0, 4.5, 5.0], U_L=8.0, U_sep=1.0, t=0.8, t_lim=1.0)
    short_unit = dict(inside, U_L=[8.0, 8.0, 4.0])
    batch = batch_of([inside, TALL, short_unit])
    codes, messages = batch.problems()
    assert codes.tolist() == [st.OK, st.OUTSIDE_DOMAIN, st.OUTSIDE_DOMAIN]
    assert "taller than the dome base radius" in messages[1]
    assert "U_L[unit 3] = 4.0 mm" in messages[2]
    rows = solve_batch(batch, "all")
    for design in (1, 2):
        mine = rows["design_index"] == design
        assert mine.sum() == 1  # one row per invalid design, with its status
        assert rows["status"][mine][0] == st.OUTSIDE_DOMAIN
        assert np.isnan(rows["energy"][mine]).all() and rows["found"][mine][0] == -1
    assert st.Status(st.OUTSIDE_DOMAIN).label == "outside_domain"


def test_states_of_the_tall_design_exit_2_with_one_line(tmp_path, capsys):
    path = tmp_path / "tall.toml"
    path.write_text("[design]\nH = [50, 50, 50]\nU_L = 8\nU_sep = 1.0\nt = 0.8\nt_lim = 1.0\n")
    assert main(["states", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "H[unit 1] = 50.0 mm: taller than the dome base radius" in err[0]


def test_fitted_range_flag_and_note():
    walker = Design(H=[1.1, 2.0], U_L=6.5, U_sep=1.0, t=1.0, t_lim=1.0)
    assert walker.in_fitted_range is False
    note = "H[unit 1] = 1.1 mm below the fitted 3-5 mm (and 1 more unit)"
    assert walker.fitted_range_note == note
    edges = Design(H=[3.0, 5.0], U_L=6.0, U_sep=1.0, t=0.5, t_lim=1.0, E=40.0)
    assert edges.in_fitted_range and edges.fitted_range_note is None
    outside = Design(H=[4.0, 4.0], U_L=6.0, U_sep=1.0, t=1.2, t_lim=1.0, E=4.0, r_b=6.0)
    assert outside.fitted_range_note == (
        "t = 1.2 mm above the fitted 0.5-1 mm; E = 4 MPa below the fitted 5-40 MPa; "
        "r_b = 6 mm above the fitted 5 mm"
    )
    batch = DesignBatch.from_designs([walker, edges, outside])
    assert batch.in_fitted_range().tolist() == [False, True, False]
    assert batch.fitted_range_notes()[1] is None
    assert set(FITTED_RANGES) >= {"H", "t", "E"}
    assert FITTED_RANGES["H"][:2] == (3.0, 5.0) and FITTED_RANGES["t"][:2] == (0.5, 1.0)
    assert FITTED_RANGES["E"][:2] == (5.0, 40.0)


def test_json_outputs_carry_the_flag(tmp_path, capsys):
    path = tmp_path / "walker.toml"
    path.write_text("[design]\nH = [1.1, 2.0]\nU_L = 6.5\nU_sep = 1.0\nt = 1.0\nt_lim = 1.0\n")
    assert main(["states", str(path), "--sequential", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["fitted_range"] is False
    assert data["fitted_range_note"].startswith("H[unit 1] = 1.1 mm below the fitted 3-5 mm")
    inside = tmp_path / "inside.toml"
    inside.write_text("[design]\nH = [4.0, 4.5]\nU_L = 6.5\nU_sep = 1.0\nt = 0.8\nt_lim = 1.0\n")
    assert main(["states", str(inside), "--sequential", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["fitted_range"] is True and data["fitted_range_note"] is None
    assert main(["states", str(inside), "--sequential"]) == 0
    assert "note:" not in capsys.readouterr().out


# --------------------------------------------------------------------- the collapsed-row invariant

OUTPUTS = ("energy", "tip_x", "tip_y", "bend_angle", "curvature", "stiffness", "min_eig")


@hs.composite
def designs(draw):
    """Designs over wide ranges of every parameter. Half of them may have domes up to 12 base
    radii tall or taller than their unit, so that the domain check decides what is solved (the
    invariant is asserted on what it accepts); the other half lie inside the domain."""
    n_units = draw(hs.integers(1, 4))
    r_b = draw(hs.floats(2.0, 10.0))
    anywhere = draw(hs.booleans())
    H = [r_b * draw(hs.floats(0.05, 12.0 if anywhere else 1.0)) for _ in range(n_units)]
    U_L = [h * draw(hs.floats(0.5 if anywhere else 1.01, 6.0)) for h in H]
    return dict(
        H=H,
        U_L=U_L,
        U_sep=[draw(hs.floats(0.05, 10.0)) for _ in range(n_units)],
        t=draw(hs.floats(0.1, 3.0)),
        t_lim=draw(hs.floats(0.1, 5.0)),
        E=draw(hs.floats(1.0, 100.0)),
        nu=draw(hs.floats(0.0, 0.49)),
        r_b=r_b,
        t_ch=draw(hs.floats(0.2, 3.0)),
    )


@settings(max_examples=100, deadline=None)
@given(design=designs())
@example(design=dict(TALL, E=26.0, nu=0.35, r_b=5.0, t_ch=1.0, U_L=[8.0] * 3, U_sep=[1.0] * 3))
def test_a_collapsed_row_carries_the_outputs_of_the_state_it_names(design):
    """Over the accepted domain: a row "collapsed to S" has the outputs of S's own row (S's
    search finds S, at the same minimum), or a status saying why not. The H = 50 design (the
    issue's) is outside the domain: rejected, not solved into contradicting rows."""
    check_collapsed_rows(design)


def check_collapsed_rows(design: dict) -> int:
    """The invariant of the test above for one design; returns the collapsed rows checked."""
    batch = batch_of([design])
    code = batch.status()[0]
    if code != st.OK:
        H, U_L, r_b = np.array(design["H"]), np.array(design["U_L"]), design["r_b"]
        outside = bool(np.any(H > r_b) or np.any(H >= U_L))
        assert (code == st.OUTSIDE_DOMAIN) == outside
        assert code in (st.OUTSIDE_DOMAIN, st.INVALID_CONSTANTS)
        return 0
    rows = solve_batch(batch, "all", stiffness=True, min_eig=True)
    by_state = {int(r): i for i, r in enumerate(rows["requested"])}
    collapsed = np.flatnonzero(rows["status"] == st.COLLAPSED)
    for i in collapsed:
        found = int(rows["found"][i])
        own = by_state[found]
        assert rows["status"][own] == st.OK, (design, i, found)
        assert rows["found"][own] == found
        for name in OUTPUTS:
            a, b = float(rows[name][i]), float(rows[name][own])
            same = a == b or abs(a - b) <= 1e-7 * max(1.0, abs(b))  # a == b: inf for N = 1
            assert same, (name, a, b, design)
    return len(collapsed)


def test_the_collapsed_row_invariant_is_exercised():
    """A design with collapsed rows, so that the invariant's loop runs: the gripper finger,
    whose requested state 00001 falls to 00000 (the seed implementation's too, reference
    gripper_states.csv), and the paper's H = 50 design, rejected before solving."""
    gripper = dict(GRIPPER, nu=0.35, r_b=5.0, t_ch=1.0)
    assert check_collapsed_rows(gripper) > 0
    rows = solve_batch(batch_of([gripper]), "all", stiffness=False, min_eig=False)
    assert rows["status"][1] == st.COLLAPSED and rows["found"][1] == 0
    tall = dict(TALL, E=26.0, nu=0.35, r_b=5.0, t_ch=1.0, U_L=[8.0] * 3, U_sep=[1.0] * 3)
    assert batch_of([tall]).status()[0] == st.OUTSIDE_DOMAIN
    assert check_collapsed_rows(tall) == 0


def test_sweep_rows_carry_the_flag_and_the_domain_status(tmp_path):
    from sweep_helpers import make_job

    from dpfexplore.sweep.driver import run_sweep
    from dpfexplore.sweep.storage import store

    spec = make_job(**{"space.variables.H": {"min": 2.0, "max": 5.4}, "job.samples_per_n": 40})
    assert spec.fitted_range_note() == "H 2-5.4 mm (fitted 3-5 mm)"  # the sweep summary's note
    assert make_job().fitted_range_note() is None
    out = tmp_path / "out"
    run_sweep(spec, out)
    field = store.read_schema(out).field("fitted_range")
    assert field.type == "bool" and b"H 3-5 mm" in field.metadata[b"description"]
    frame = store.read_results(out)
    H = frame[[f"H_{k}" for k in (1, 2, 3)]].to_numpy()
    inside = np.all(np.isnan(H) | ((H >= 3.0) & (H <= 5.0)), axis=1) & frame.t.between(0.5, 1.0)
    assert (frame.fitted_range == inside).all()
    assert frame.fitted_range.any() and not frame.fitted_range.all()
    tall = np.nanmax(H, axis=1) > 5.0
    assert tall.any()
    assert (frame.status_label[tall] == "outside_domain").all()
    assert frame.problem[tall].str.contains("taller than the dome base radius").all()
    assert (frame.status_label[~tall] != "outside_domain").all()
