"""Constants sets that every computation runs on (issue 20 §1).

A set other than the paper's must change exactly what it says (``k_b``, ``alpha``, the reach)
everywhere: the kernel tables, the validation, the fitted-range flag, the sensitivities (through
the set's own derivatives, against finite differences) and the states.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from model_helpers import FINGER, other_set

from dpfexplore import Design, find_state
from dpfexplore._kernels import layout as lay
from dpfexplore._kernels.tables.set_forms import DOME_BLOCK
from dpfexplore.model.constants_set import (
    DEFAULT,
    ClosedForm,
    ConstantsSet,
    ConstantsSetError,
    load_constants_set,
)
from dpfexplore.model.design import DesignBatch, load_design
from dpfexplore.model.status import Status
from dpfexplore.solvers.lattice import batch_constants, kernel_tables, spring_constants


def test_a_set_changes_the_kernel_tables_as_its_forms_say():
    other = other_set()
    paper = Design(**FINGER)
    design = Design(**FINGER, constants=other)
    assert design != paper and design.constants is other
    H, t = np.array(FINGER["H"]), 0.8
    want = other.evaluate(H, t, 5.0, 26.0)
    table = kernel_tables(DesignBatch.from_designs([design])).unit_params[0, :3]
    # the compiled path and the set's NumPy methods agree bit for bit
    np.testing.assert_array_equal(table[:, lay.COL_KB], want["k_b"])
    np.testing.assert_array_equal(table[:, lay.COL_ALPHA], want["alpha"])
    np.testing.assert_array_equal(
        table[:, lay.COL_D], want["tip_dis"] - H - np.array(FINGER["U_sep"]) - 0.5 - t / 2
    )
    # k_b is 1.3 times the paper's (the same alpha terms plus one, a different tip)
    paper_kb = spring_constants(paper).k_b
    np.testing.assert_allclose(table[:, lay.COL_KB], 1.3 * paper_kb, rtol=1e-14)
    c = spring_constants(design)
    np.testing.assert_array_equal(c.k_b, table[:, lay.COL_KB])
    batch = batch_constants(DesignBatch.from_designs([design]))
    np.testing.assert_array_equal(batch["alpha"][0, :3], table[:, lay.COL_ALPHA])
    # and the states move: a stiffer dome spring gives another energy
    a, b = find_state(paper, "010"), find_state(design, "010")
    assert a.status == b.status == Status.OK
    assert abs(a.energy - b.energy) > 1e-3 * abs(a.energy)


@pytest.mark.parametrize("constants", [DEFAULT, other_set()], ids=["paper", "other"])
def test_every_path_of_a_sets_numbers_agrees_bit_for_bit(constants):
    # Three evaluations of one set: the kernels' blocks, the NumPy forms (arrays) and
    # ConstantsSet.dome (one dome in floats, what validation uses); and the sequential plan
    # built from the kernel tables (solve_batch) against the one built from the NumPy forms.
    from dpfexplore.solvers.row_plan import sequential_state_table

    rng = np.random.default_rng(4)
    designs = [
        Design(
            H=rng.uniform(3.0, 5.0, n).tolist(),
            U_L=8.0,
            U_sep=rng.uniform(1.0, 3.0, n).tolist(),
            t=float(rng.uniform(0.5, 1.0)),
            t_lim=1.5,
            E=float(rng.uniform(5.0, 40.0)),
            constants=constants,
        )
        for n in rng.integers(2, 12, 100)  # about 650 domes: more than one dome block
    ]
    batch = DesignBatch.from_designs(designs)
    assert batch.n_units.sum() > DOME_BLOCK
    tables = kernel_tables(batch)
    for i, design in enumerate(designs):
        n = design.n_units
        for j in range(n):
            k_b, alpha = constants.dome(design.E, design.H[j], design.t, design.r_b)
            assert k_b == tables.unit_params[i, j, lay.COL_KB]
            assert alpha == tables.unit_params[i, j, lay.COL_ALPHA]
        want = constants.evaluate(np.asarray(design.H), design.t, design.r_b, design.E)
        np.testing.assert_array_equal(want["k_b"], tables.unit_params[i, :n, lay.COL_KB])
    valid = tables.status == Status.OK
    assert valid.sum() > 80  # most of them: the comparison below is not vacuous
    np.testing.assert_array_equal(
        sequential_state_table(batch, tables)[valid], sequential_state_table(batch)[valid]
    )


def test_the_paper_set_through_the_general_path_reproduces_the_compiled_forms():
    design = Design(**FINGER)
    assert design.constants == DEFAULT
    table = kernel_tables(DesignBatch.from_designs([design])).unit_params[0, :3]
    from dpfexplore.model.constants import dome_alpha, dome_radius, dome_stiffness

    H = np.array(FINGER["H"])
    R = dome_radius(H, 5.0)
    np.testing.assert_allclose(table[:, lay.COL_KB], dome_stiffness(26.0, H, 0.8, R), rtol=1e-13)
    np.testing.assert_allclose(table[:, lay.COL_ALPHA], dome_alpha(H, 0.8, R), rtol=1e-13)


def test_the_fitted_range_flag_uses_the_sets_own_domain():
    other = other_set()
    # H = 3 mm at r_b = 5 is H/r_b = 0.6, inside both; nu = 0.3 is inside 'other' only ...
    inside = Design(**FINGER, nu=0.3, constants=other)
    assert inside.in_fitted_range
    assert Design(**FINGER, nu=0.3).in_fitted_range  # the paper's set states no nu range
    # ... r_b = 6 with H/r_b and t/r_b in range: outside the paper's r_b = 5, inside 'other'
    scaled = {**FINGER, "H": [4.8, 5.28, 4.32], "t": 0.96, "U_L": 9.6}
    assert Design(**scaled, r_b=6.0, constants=other).in_fitted_range
    assert Design(**scaled, r_b=6.0).fitted_range_note == (
        "H[unit 2] = 5.28 mm above the fitted 3-5 mm; r_b = 6 mm above the fitted 5 mm"
    )
    low = Design(**{**FINGER, "H": [2.5, 4.0, 4.0]}, nu=0.25, constants=other)
    assert low.fitted_range_note == (
        "H/r_b[unit 1] = 0.5 below the fitted 0.6-1; nu = 0.25 below the fitted 0.3-0.49"
    )


def test_validation_names_the_set_whose_forms_are_nonsense():
    # alpha = 0.9 + 0.2 pi1: above 1 for thick domes (t/H > 0.5), unphysical only outside
    # the domain the set claims (so the set itself is accepted)
    steep = ConstantsSet(
        name="steep",
        k_hat=DEFAULT.k_hat,
        alpha=ClosedForm(((0, 0), (1, 0)), (0.9, 0.2)),
        tip_ratio=DEFAULT.tip_ratio,
        domain={"H_over_rb": (0.6, 1.0), "t_over_rb": (0.1, 0.2)},
    )
    with pytest.raises(ValueError, match=r"closed forms of constants set 'steep' .*alpha = 1\.0"):
        Design(H=[1.5], U_L=8.0, U_sep=1.5, t=1.0, t_lim=1.5, constants=steep)


def test_one_batch_takes_one_set():
    with pytest.raises(ValueError, match="one batch takes one constants set"):
        DesignBatch.from_designs([Design(**FINGER), Design(**FINGER, constants=other_set())])
    batch = DesignBatch.from_designs([Design(**FINGER, constants=other_set())] * 3)
    assert batch.take(np.array([0, 2])).constants == other_set()
    assert batch.design(1).constants == other_set()
    assert DesignBatch.concatenate([batch, batch]).constants == other_set()


def test_sets_travel_by_file_from_the_api_and_from_design_files(tmp_path):
    path = other_set().save(tmp_path / "sets" / "other.json")
    assert Design(**FINGER, constants=str(path)).constants == other_set()
    (tmp_path / "finger.toml").write_text(
        "[design]\nH = [4.0, 4.4, 3.6]\nU_L = 8.0\nU_sep = 1.5\nt = 0.8\nt_lim = 1.5\n"
        'constants = "sets/other.json"\n'
    )
    assert load_design(tmp_path / "finger.toml").constants == other_set()
    path.write_text(path.read_text().replace("2.1", "2.2"))
    with pytest.raises(ValueError, match="fingerprint"):
        load_design(tmp_path / "finger.toml")
    with pytest.raises(ConstantsSetError, match="unknown domain range 'height'"):
        ConstantsSet(
            name="x",
            k_hat=DEFAULT.k_hat,
            alpha=DEFAULT.alpha,
            tip_ratio=DEFAULT.tip_ratio,
            domain={"height": (3.0, 5.0)},
        )


def test_derivative_tables_follow_the_sets_own_derivatives():
    """The kernels' derivative table of k_b, alpha and d against central differences of the
    set's own NumPy evaluation (the chain rule through π1, π3 and R, for any set)."""
    other = other_set()
    rng = np.random.default_rng(7)
    n = 60
    H, t, U_sep = rng.uniform(3.0, 5.0, n), rng.uniform(0.5, 1.0, n), rng.uniform(1.0, 2.0, n)
    designs = [
        Design(H=[h], U_L=8.0, U_sep=u, t=s, t_lim=1.5, constants=other)
        for h, s, u in zip(H, t, U_sep, strict=True)
    ]
    tables = kernel_tables(DesignBatch.from_designs(designs), derivatives=True)
    dtab = tables.derivatives[:, 0]
    step = 1e-5

    def at(Hs, ts):
        values = other.evaluate(Hs, ts, 5.0, 26.0)
        values["d"] = values["tip_dis"] - Hs - U_sep - 0.5 - ts / 2
        return values

    for j, (dH, dt) in ((0, (step, 0.0)), (3, (0.0, step))):  # DP_H, DP_T
        hi, lo = at(H + dH, t + dt), at(H - dH, t - dt)
        for name, row in (("k_b", lay.COL_KB), ("alpha", lay.COL_ALPHA), ("d", lay.COL_D)):
            fd = (hi[name] - lo[name]) / (2 * step)
            np.testing.assert_allclose(dtab[:, row, j], fd, rtol=1e-7, atol=1e-9, err_msg=name)


def test_a_hull_narrows_the_domain_to_where_the_data_were(tmp_path):
    """A set fitted on a triangle of (H/r_b, t/r_b) flags the box corner it never saw."""
    from dpfexplore.model.constants_set import data_hull

    h = [0.6, 1.0, 0.6, 0.8]
    s = [0.1, 0.1, 0.2, 0.12]  # the last point is inside: not a vertex
    hull = data_hull(h, s)
    assert hull is not None and len(hull) == 3
    triangle = ConstantsSet(
        name="triangle",
        k_hat=DEFAULT.k_hat,
        alpha=DEFAULT.alpha,
        tip_ratio=DEFAULT.tip_ratio,
        domain={"H_over_rb": (0.6, 1.0), "t_over_rb": (0.1, 0.2)},
        hull=hull,
    )
    # inside the triangle, and the corner (1.0, 0.2) of the box that is not
    assert triangle.in_domain([3.5, 5.0], [0.6, 1.0], 5.0, 26.0).tolist() == [True, False]
    corner = Design(H=[5.0], U_L=8.0, U_sep=1.5, t=1.0, t_lim=1.5, constants=triangle)
    assert corner.fitted_range_note == (
        "(H/r_b, t/r_b)[unit 1] = (1, 0.2) outside the hull of the data the constants set was "
        "fitted on"
    )
    assert Design(H=[3.5], U_L=8.0, U_sep=1.5, t=0.6, t_lim=1.5, constants=triangle).in_fitted_range
    # the hull is part of the set: saved, fingerprinted, read back
    path = triangle.save(tmp_path / "triangle.json")
    again = load_constants_set(path)
    assert again.hull == triangle.hull and again == triangle
    assert again.fingerprint != dataclasses.replace(triangle, hull=None).fingerprint
    # collinear data have no hull (the ranges say all there is)
    assert data_hull([0.6, 0.8, 1.0], [0.1, 0.15, 0.2]) is None


def test_negative_powers_down_to_the_limit_in_the_kernels():
    """Powers down to -MAX_POWER: the tables bit for bit, the derivatives (which reach one
    power lower) against central differences of the set's NumPy evaluation."""
    from dpfexplore.model.closed_form import MAX_POWER

    low = -MAX_POWER
    steep = ConstantsSet(
        name="negative",
        k_hat=ClosedForm(((0, 0), (low, 1), (2, low), (-1, -1)), (0.5, 1e-6, 1e-3, 0.01)),
        alpha=ClosedForm(((0, 0), (1, low), (low, 2), (3, 0)), (0.05, 1e-3, 1e-7, -0.2)),
        tip_ratio=ClosedForm(((0, 0), (1, -1)), (2.0, 0.1)),
        domain=dict(DEFAULT.domain),
    )
    rng = np.random.default_rng(11)
    n = 50
    H, t, U_sep = rng.uniform(3.0, 5.0, n), rng.uniform(0.5, 1.0, n), rng.uniform(1.0, 2.0, n)
    per_unit = np.full((3, n, 12), np.nan)
    per_unit[:, :, 0] = H, np.full(n, 8.0), U_sep
    batch = DesignBatch(
        n_units=np.ones(n, dtype=np.int64),
        H=per_unit[0],
        U_L=per_unit[1],
        U_sep=per_unit[2],
        t=t,
        t_lim=1.5,
        E=26.0,
        nu=0.35,
        r_b=5.0,
        t_ch=1.0,
        constants=steep,
    )
    tables = kernel_tables(batch, derivatives=True)
    want = steep.evaluate(H, t, 5.0, 26.0)
    np.testing.assert_array_equal(tables.unit_params[:, 0, lay.COL_KB], want["k_b"])
    np.testing.assert_array_equal(tables.unit_params[:, 0, lay.COL_ALPHA], want["alpha"])
    step = 1e-5
    for j, (dH, dt) in ((0, (step, 0.0)), (3, (0.0, step))):  # DP_H, DP_T
        hi = steep.evaluate(H + dH, t + dt, 5.0, 26.0)
        lo = steep.evaluate(H - dH, t - dt, 5.0, 26.0)
        for name, row in (("k_b", lay.COL_KB), ("alpha", lay.COL_ALPHA)):
            fd = (hi[name] - lo[name]) / (2 * step)
            np.testing.assert_allclose(
                tables.derivatives[:, 0, row, j], fd, rtol=1e-7, atol=1e-9, err_msg=name
            )


def test_a_set_read_twice_is_checked_once_and_a_tampered_copy_still_refused():
    # from_dict keeps the sets it has checked by fingerprint (estimators read theirs on every
    # prediction); the fingerprint is still verified on every read.
    data = other_set().to_dict()
    first = ConstantsSet.from_dict(data)
    assert ConstantsSet.from_dict(data) is first and first == other_set()
    tampered = dict(data, alpha={"terms": [{"pi1": 0, "pi3": 0, "coefficient": 0.5}]})
    with pytest.raises(ConstantsSetError, match="do not match its fingerprint"):
        ConstantsSet.from_dict(tampered)
