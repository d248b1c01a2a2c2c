"""Refinement of lookup candidates with the exact model: targets met to 1e-6 mm, bounds and
constraints honoured exactly, collapses and bounds reported instead of silently kept."""

from __future__ import annotations

import numpy as np
import pytest
from sweep_helpers import make_job

from dpfexplore import Design, DesignBatch, find_state, solve_batch
from dpfexplore.lookup.polish import (
    _central_differences,
    _model_outputs,
    parse_constraints,
    refine,
    variables_for,
)
from dpfexplore.lookup.query import designs_of, lookup
from dpfexplore.model.variables import DesignVariables
from dpfexplore.sweep.driver import run_sweep

BOX = {
    "H": (3.0, 5.0),
    "U_L": (5.5, 10.0),
    "U_sep": (1.0, 5.0),
    "t": (0.5, 1.0),
    "t_lim": (1.0, 2.0),
}


@pytest.fixture(scope="module")
def inverted(tmp_path_factory):
    """N = 3, 4, all units inverted, stiffness; the paper's box, per-unit U_L and U_sep."""
    spec = make_job(**{"job.name": "inv", "job.samples_per_n": 120, "space.n_units": [3, 4]})
    path = tmp_path_factory.mktemp("refine") / "inv"
    run_sweep(spec, path)
    return spec, path


def held_out_tip(n_units: int, seed: int) -> tuple[Design, np.ndarray]:
    """A random design of the box (not in any dataset) whose all-inverted state exists."""
    rng = np.random.default_rng(seed)
    while True:
        design = Design(
            H=rng.uniform(*BOX["H"], n_units),
            U_L=rng.uniform(*BOX["U_L"], n_units),
            U_sep=rng.uniform(*BOX["U_sep"], n_units),
            t=rng.uniform(*BOX["t"]),
            t_lim=rng.uniform(*BOX["t_lim"]),
        )
        result = find_state(design, "1" * n_units)
        if result.stable:
            return design, result.tip


def in_box(design: Design) -> bool:
    return all(
        all(
            BOX[name][0] - 1e-12 <= v <= BOX[name][1] + 1e-12
            for v in np.atleast_1d(getattr(design, name))
        )
        for name in BOX
    )


@pytest.mark.parametrize("seed", [3, 4])
def test_target_from_a_known_design_is_met(inverted, seed):
    _, path = inverted
    _, target = held_out_tip(3 + seed % 2, seed)
    result = lookup(path, target, k=3, refine=True)
    assert result.reachable
    # the same from the central-difference baseline
    _, rows = result.index.query(target, 1)
    start = designs_of(result.index, rows).design(0)
    variables = variables_for(make_job(**{"space.n_units": [3, 4]}).space, start)
    baseline = refine(
        start,
        int(result.index.requested[rows[0]]),
        target,
        variables=variables,
        sensitivities="central",
    )
    assert baseline.status == "ok" and baseline.error <= 1e-6
    best = result.best
    assert best.status == "ok" and best.met and best.refined and best.error <= 1e-6
    # independently of the lookup's own verification
    again = find_state(best.design, best.state)
    assert again.stable
    assert np.linalg.norm(again.tip - target) <= 1e-6
    assert np.array_equal(again.tip, best.tip)
    assert in_box(best.design)
    # the start and the final design both solved (a collapsed start returns "collapsed"), so at
    # most evaluations - 2 trial designs collapsed; within the default budget of 60
    ref = best.refinement
    assert 2 <= ref.evaluations <= 60
    assert 0 <= ref.collapses <= ref.evaluations - 2
    assert ref.status == "ok" and ref.error <= 1e-6


def test_refinement_honours_bounds_and_constraints(inverted):
    spec, path = inverted
    _, target = held_out_tip(4, 11)
    constraints = {
        "heights": "descending",
        "shared_U_L": True,
        "shared_U_sep": True,
        "t": [0.6, 0.7],
        "tied": [[3, 4]],
    }
    result = lookup(path, target, k=4, n_units=(4,), refine=True, constraints=constraints)
    assert any(c.status == "ok" for c in result.candidates)
    for c in result.candidates:
        d = c.design
        assert all(a >= b for a, b in zip(d.H, d.H[1:], strict=False))
        assert d.H[2] == d.H[3]
        assert len(set(d.U_L)) == 1 and len(set(d.U_sep)) == 1
        assert 0.6 <= d.t <= 0.7
        assert in_box(d)
        variables = variables_for(spec.space, d, constraints)
        assert variables.contains(DesignBatch.from_designs([d]), tol=1e-12)[0]
        if c.status == "ok":
            assert c.error <= 1e-6
            assert np.linalg.norm(find_state(d, c.state).tip - target) <= 1e-6
        else:
            assert c.status in ("not_met", "collapsed") and c.error > 1e-6


def test_constraints_that_contradict_the_job_are_refused(tmp_path):
    ascending = make_job(
        **{"space.constraints.heights": "ascending", "space.constraints.equal_U_L": True}
    )
    design = Design(H=[3.5, 4.0, 4.5], U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.5)
    with pytest.raises(ValueError, match="contradicts the job's 'ascending'"):
        variables_for(ascending.space, design, {"heights": "descending"})
    with pytest.raises(ValueError, match="shared_U_L = false"):
        variables_for(ascending.space, design, {"shared_U_L": False})
    with pytest.raises(ValueError, match="outside the job's box"):
        variables_for(ascending.space, design, {"t": [1.2, 1.5]})
    with pytest.raises(ValueError, match="unknown key 'E'"):
        variables_for(ascending.space, design, {"E": 30.0})
    variables = variables_for(ascending.space, design, {"t": 0.8})
    assert variables.heights == "ascending" and variables.shared_U_L
    assert "t" not in variables.names and variables.bounds_of("t") == (0.8, 0.8)


def test_parse_constraints():
    parsed = parse_constraints(
        [
            "heights=descending",
            "shared=U_L,U_sep",
            "t=0.6:0.9",
            "t_lim=1.5",
            "tied=5,6;7-8",
            "ordered_units=1-4",
        ]
    )
    assert parsed == {
        "heights": "descending",
        "shared_U_L": True,
        "shared_U_sep": True,
        "t": [0.6, 0.9],
        "t_lim": 1.5,
        "tied": [[5, 6], [7, 8]],
        "ordered_units": [1, 2, 3, 4],
    }
    for bad in ("heights", "shared=E", "t=a:b", "colour=red"):
        with pytest.raises(ValueError, match="constraint"):
            parse_constraints([bad])


# A two-unit finger whose all-inverted state exists for H_2 above ~3.72 mm only (t = 1 mm).
FOLD = dict(U_L=7.0, U_sep=2.0, t=1.0, t_lim=1.5)


def one_height(low: float, high: float) -> DesignVariables:
    """Only H_2 free, in [low, high]."""
    return DesignVariables(n_units=2, H=[4.5, (low, high)], U_L=7.0, U_sep=2.0, t=1.0, t_lim=1.5)


def tip_at(h2: float) -> np.ndarray:
    result = find_state(Design(H=[4.5, h2], **FOLD), "11")
    assert result.stable
    return result.tip


def test_a_state_that_collapses_on_the_way_is_reported():
    # the fold: "11" exists at 3.8 mm, not at 3.6 mm
    assert not find_state(Design(H=[4.5, 3.6], **FOLD), "11").stable
    # a target beyond the fold: where the tip would go if the state survived lower heights
    target = tip_at(3.8) + 6.0 * (tip_at(3.8) - tip_at(3.9))
    result = refine(Design(H=[4.5, 4.5], **FOLD), "11", target, variables=one_height(3.0, 5.0))
    assert result.status == "collapsed" and result.collapses >= 1
    assert "collapsed" in result.message
    # the reported design is the best one where the state exists, near the fold
    assert find_state(result.design, "11").stable
    assert 3.6 < result.design.H[1] < 3.8
    assert result.error > 1e-6
    assert result.error == pytest.approx(np.linalg.norm(tip_at(result.design.H[1]) - target))


def test_a_start_without_the_state_is_collapsed_at_once():
    target = tip_at(4.0)
    result = refine(Design(H=[4.5, 3.2], **FOLD), "11", target, variables=one_height(3.0, 5.0))
    assert result.status == "collapsed" and result.evaluations == 1
    assert np.isnan(result.error) and "does not exist" in result.message


def test_bounds_stop_the_refinement_short():
    target = tip_at(4.3) + 3.0 * (tip_at(4.3) - tip_at(4.2))  # beyond H_2 = 4.3 upward
    result = refine(Design(H=[4.5, 4.0], **FOLD), "11", target, variables=one_height(3.9, 4.3))
    assert result.status == "not_met" and result.collapses == 0
    assert result.design.H[1] == pytest.approx(4.3, abs=1e-6)
    assert result.error > 1e-3


def test_exact_and_central_difference_sensitivities_agree_with_wider_differences():
    design = Design(H=[4.2, 3.9, 4.6], U_L=[6.0, 8.0, 7.0], U_sep=[2.0, 3.0, 1.5], t=0.7, t_lim=1.4)
    batch = DesignBatch.from_designs([design])
    columns = ("tip_x", "tip_y", "stiffness")
    values, exact, status = _model_outputs(batch, 7, columns, derivatives=True)
    same, central, _ = _central_differences(batch, 7, columns, derivatives=True)
    assert status == 0 and exact.shape == central.shape == (3, 12)
    np.testing.assert_array_equal(values, same)
    theta = np.concatenate([design.H, design.U_L, design.U_sep, [design.t, design.t_lim, design.E]])
    for j in range(theta.size):
        h = 1e-4 * max(abs(theta[j]), 1.0)
        rows = []
        for sign in (1, -1):
            p = theta.copy()
            p[j] += sign * h
            one = Design(H=p[:3], U_L=p[3:6], U_sep=p[6:9], t=p[9], t_lim=p[10], E=p[11])
            out = solve_batch(DesignBatch.from_designs([one]), [7], min_eig=False)
            rows.append([out[c][0] for c in columns])
        wide = (np.array(rows[0]) - np.array(rows[1])) / (2 * h)
        np.testing.assert_allclose(central[:, j], wide, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(exact[:, j], wide, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(exact, central, rtol=1e-6, atol=1e-9)
    # shapes do not depend on E; stiffness is proportional to it
    np.testing.assert_allclose(central[:2, -1], 0.0, atol=1e-8)
    assert exact[2, -1] == pytest.approx(values[2] / design.E, rel=1e-12)
