"""The traced path: energy consistency, branches, zero-force states, the issue's findings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dpfexplore.identification.curves import curves_from_frame
from dpfexplore.model.constants import dome_stiffness
from dpfexplore.unitcell import UnitCellRun, unit_cell_curve
from dpfexplore.unitcell.checks import shallow_shell_stiffness

BOX = [(H, t) for H in (3.0, 4.0, 5.0) for t in (0.5, 0.75, 1.0)]


@pytest.fixture(scope="module")
def box_runs() -> dict[tuple[float, float], UnitCellRun]:
    """The paper's box (r_b 5, E 26) at the default mesh and step."""
    return {(H, t): unit_cell_curve(H, t) for H, t in BOX}


def test_work_of_the_reaction_equals_the_energy_change():
    # Hermite quadrature per step: its error falls with the step; at travel/300 it is < 1e-6.
    run = unit_cell_curve(3.0, 0.83, n_elements=32, step=2.2 * 3.0 / 300)
    assert run.status == "reached"
    assert np.max(np.abs(run.work - run.energy)) <= 1e-6 * np.max(run.energy)


def test_record_shapes_and_invariants():
    run = unit_cell_curve(3.0, 0.83, n_elements=48)
    n = run.n_steps
    assert run.success and run.status == "reached"
    assert run.displacement[0] == 0.0 and run.energy[0] < 1e-12
    for name in ("force", "energy", "membrane_energy", "bending_energy", "stable", "branch"):
        assert getattr(run, name).shape == (n,)
    assert run.shapes.shape == (n, 49, 2)
    np.testing.assert_allclose(run.energy, run.membrane_energy + run.bending_energy)
    # apex on the axis at z = H - delta, edge pinned
    np.testing.assert_allclose(run.shapes[:, 0, 0], 0.0)
    np.testing.assert_allclose(run.shapes[:, 0, 1], 3.0 - run.displacement)
    np.testing.assert_allclose(run.shapes[:, -1], np.tile([5.0, 0.0], (n, 1)))
    # branch ids step by one at every fold, where d(delta)/ds changes sign
    assert np.all(np.diff(run.branch) >= 0) and np.all(np.diff(run.branch) <= 1)
    assert run.displacement[-1] >= 2.2 * 3.0
    # the force is the slope of the energy on a stable stretch of the first branch
    first = (run.branch == 0) & run.stable
    d, e, f = run.displacement[first], run.energy[first], run.force[first]
    slope = np.gradient(e, d)
    np.testing.assert_allclose(slope[5:-5], f[5:-5], rtol=2e-2)


def test_every_box_dome_folds_before_1p9_H_and_rests_inverted_near_2_H(box_runs):
    for (H, t), run in box_runs.items():
        assert run.status == "reached", (H, t, run.message)
        first_fold = run.folds[0]
        assert 1.7 * H < first_fold < 1.9 * H, (H, t, first_fold / H)
        # past the fold the dome jumps to an inverted branch where the force is negative
        assert np.any(run.force[run.displacement > first_fold] < 0.0)
        # a stable zero-force inverted state: bistable, thick low domes included
        assert run.bistable, (H, t)
        assert 2.0 * H <= run.tip_dis < 2.08 * H, (H, t, run.tip_dis / H)


def test_tip_dis_is_a_few_percent_below_the_papers_fit(box_runs):
    for (H, t), run in box_runs.items():
        paper = 0.2565 * t + 2.1425 * H  # MODEL.md §11, the two-unit contact runs
        assert -0.10 < run.tip_dis / paper - 1.0 < -0.02, (H, t)


def test_initial_stiffness_is_reissners_not_the_papers_k_b(box_runs):
    for (H, t), run in box_runs.items():
        R = run.R
        reissner = shallow_shell_stiffness(run.E, run.nu, t, R)
        paper = float(dome_stiffness(run.E, H, t, R))
        assert abs(run.initial_stiffness / reissner - 1.0) < 0.12, (H, t)
        assert run.initial_stiffness < paper, (H, t)
    ratios = [
        float(dome_stiffness(26.0, H, t, r.R)) / r.initial_stiffness
        for (H, t), r in box_runs.items()
    ]
    assert max(ratios) > 2.0  # the paper's k_b is up to ~2.3 times the shell's initial slope


def test_zero_force_states_are_refined_equilibria(box_runs):
    run = box_runs[(3.0, 1.0)]
    states = run.zero_force_states
    assert all(s.refined for s in states)
    stable = [s for s in states if s.stable]
    assert len(stable) == 1 and stable[0].displacement == run.tip_dis
    # the unstable ones are saddles of the free dome (at least one negative eigenvalue)
    assert all(s.index >= 1 for s in states if not s.stable)


def test_to_frame_is_the_identification_table(box_runs):
    run = box_runs[(4.0, 0.75)]
    frame = run.to_frame(curve="a")
    assert list(frame.columns) == [
        "curve",
        "H",
        "t",
        "r_b",
        "E",
        "nu",
        "displacement",
        "energy",
        "force",
        "branch",
        "tip_dis",
    ]
    (curve,) = curves_from_frame(frame)
    assert curve.folded and curve.tip_dis == pytest.approx(run.tip_dis)
    assert curve.displacement[0] == 0.0
    # its lower envelope: the first branch, then the inverted branch once it is lower
    assert np.all(np.isfinite(curve.energy))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(H=-1.0, t=0.5), "H"),
        (dict(H=3.0, t=0.0), "t"),
        (dict(H=3.0, t=6.0), "t"),
        (dict(H=3.0, t=0.5, r_b=math.nan), "r_b"),
        (dict(H=3.0, t=0.5, E=0.0), "E"),
        (dict(H=3.0, t=0.5, nu=0.5), "nu"),
        (dict(H=3.0, t=0.5, n_elements=2), "n_elements"),
        (dict(H=3.0, t=0.5, travel=-1.0), "travel"),
        (dict(H=3.0, t=0.5, travel="far"), "travel"),
        (dict(H=3.0, t=0.5, step=math.inf), "step"),
        (dict(H=3.0, t=0.5, max_steps=0), "max_steps"),
        (dict(H=3.0, t=0.5, grading=0.95), "grading"),
        (dict(H="3", t=0.5), "H"),
    ],
)
def test_bad_inputs_are_one_line_errors_naming_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}=") as error:
        unit_cell_curve(**kwargs)
    assert "\n" not in str(error.value)


def test_a_path_that_stops_early_gets_the_inverted_branch_from_the_mirror_image():
    # Fine apex elements let the first element collapse onto the axis on a high-index branch
    # (a point load on a tiny element): the trace stops there, and the inverted branch is
    # traced from the dome's mirror image instead.
    run = unit_cell_curve(5.0, 1.0, n_elements=128, grading=0.5)
    assert run.status == "partial" and run.gap is not None
    assert run.branch[run.gap + 1] == run.branch[run.gap] + 1
    assert run.displacement[run.gap] not in run.folds  # the gap is not a fold
    assert run.tip_dis == pytest.approx(unit_cell_curve(5.0, 1.0).tip_dis, rel=1e-4)
    # the appended piece runs from just past the inverted branch's own fold up to the travel
    after = slice(run.gap + 2, None)
    assert run.displacement[-1] >= 2.2 * 5.0 and np.all(run.stable[after])
    assert abs(run.work[-1] - run.energy[-1]) <= 1e-4 * run.energy.max()


def test_a_shallow_thick_dome_is_monostable_and_its_ghost_gives_tip_dis():
    run = unit_cell_curve(1.2, 1.0, r_b=7.0)
    assert run.status == "reached" and run.folds.size == 0
    assert not run.bistable and run.tip_kind == "ghost"
    assert np.all(run.force[1:] > 0.0)
    ghost = run.ghost
    assert run.tip_dis == ghost.displacement and ghost.displacement > run.H
    # the least force past H: no point of the path lies below it, the points around it bracket
    # it, and the force's finite-difference slope changes sign there
    past = run.displacement > run.H
    assert ghost.force > 0.0 and ghost.force <= run.force[past].min() + 1e-9
    slope = np.gradient(run.force, run.displacement)
    before = run.displacement < ghost.displacement
    assert slope[past & before][-1] < 0.0 < slope[past & ~before][0]
    # third order in the step: a tenth of the step moves it by far less than the step
    fine = unit_cell_curve(1.2, 1.0, r_b=7.0, step=run.displacement[-1] / 600)
    assert abs(fine.ghost.displacement - ghost.displacement) < 1e-5 * ghost.displacement
    assert fine.ghost.force == pytest.approx(ghost.force, rel=1e-5)
    frame = run.to_frame()
    assert frame["tip_dis"].iloc[0] == run.tip_dis
    (curve,) = curves_from_frame(frame)
    assert not curve.folded and curve.force is not None


def test_a_nearly_flat_thick_dome_has_no_tip_dis():
    # the force only rises past H: neither an inverted rest nor a least force
    run = unit_cell_curve(0.5, 1.0)
    assert run.status == "reached" and np.all(np.diff(run.force) > 0.0)
    assert run.tip_kind is None and run.tip_dis is None and run.ghost is None
    assert "tip_dis" not in run.to_frame()


def test_the_rest_merges_into_the_ghost_at_the_bistable_edge():
    # t = 1, r_b = 5: H = 1.3 has only a ghost, H = 1.5 rests inverted; at the saddle-node
    # between them the rest and the barrier meet at the least force, so the travel that
    # tip_dis reports is continuous across the edge (a square-root approach on the rest's side)
    lo, hi = 1.3, 1.5
    for _ in range(16):
        mid = 0.5 * (lo + hi)
        if unit_cell_curve(mid, 1.0).tip_kind == "rest":
            hi = mid
        else:
            lo = mid
    ghost, rest = unit_cell_curve(lo, 1.0), unit_cell_curve(hi, 1.0)
    assert ghost.tip_kind == "ghost" and rest.tip_kind == "rest"
    assert ghost.ghost.force < 1e-3 * ghost.force.max()  # the minimum touches zero
    assert abs(rest.tip_dis - ghost.tip_dis) < 0.005 * rest.tip_dis
    # far from the edge the two differ plainly: the test resolves the approach
    assert unit_cell_curve(1.46, 1.0).tip_dis - unit_cell_curve(1.44, 1.0).tip_dis > 0.05


def test_linear_elasticity_and_geometric_similarity():
    # Energy scales with E and with the cube of the size; the shapes do not depend on E.
    base = unit_cell_curve(3.0, 0.8, 5.0, 26.0, 0.35, n_elements=32)
    soft = unit_cell_curve(3.0, 0.8, 5.0, 13.0, 0.35, n_elements=32)
    big = unit_cell_curve(6.0, 1.6, 10.0, 26.0, 0.35, n_elements=32)
    assert soft.n_steps == base.n_steps
    np.testing.assert_allclose(soft.displacement, base.displacement, atol=1e-9)
    np.testing.assert_allclose(soft.energy, 0.5 * base.energy, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(big.tip_dis, 2.0 * base.tip_dis, rtol=1e-8)
    np.testing.assert_allclose(big.folds, 2.0 * base.folds, rtol=1e-6)
    np.testing.assert_allclose(big.initial_stiffness, 2.0 * base.initial_stiffness, rtol=1e-8)
    energies = [s.energy for s in base.zero_force_states]
    np.testing.assert_allclose(
        [s.energy for s in big.zero_force_states], 8.0 * np.array(energies), rtol=1e-6
    )
