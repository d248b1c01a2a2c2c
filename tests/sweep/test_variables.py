"""Design variables of inverse problems: the map from the unit box honours every constraint."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from dpfexplore.model.design import Design, DesignBatch
from dpfexplore.model.variables import DesignVariables, parameter_names

GRIPPER = dict(
    n_units=5,
    H=[(3.0, 5.0)] * 4 + [(2.0, 5.0)],
    heights="ascending",
    ordered_units=(1, 2, 3, 4),
    U_L=(5.5, 10.0),
    U_sep=(1.0, 5.0),
    t=(0.5, 1.0),
    t_lim=(1.0, 2.0),
)
PICKPLACE = dict(
    n_units=6,
    H=[4.0, 4.5, 5.0, 5.0, (2.5, 5.0), (2.5, 5.0)],
    tied=[(5, 6)],
    U_L=6.0,
    U_sep=1.0,
    t=(0.5, 1.0),
    t_lim=1.0,
)
CASES = {
    "descending": dict(n_units=5, heights="descending"),
    "ascending-per-unit": dict(
        n_units=4, heights="ascending", shared_U_L=False, shared_U_sep=False
    ),
    "gripper": GRIPPER,
    "pickplace": PICKPLACE,
    "free-N1": dict(n_units=1),
}


def _z(variables, data):
    return np.array(
        data.draw(
            hs.lists(
                hs.floats(0.0, 1.0), min_size=variables.n_variables, max_size=variables.n_variables
            )
        )
    )


@pytest.mark.parametrize("case", sorted(CASES))
@settings(max_examples=60, deadline=None)
@given(data=hs.data())
def test_every_point_of_the_box_is_a_feasible_design(case, data):
    variables = DesignVariables(**CASES[case])
    z = _z(variables, data)
    design = variables.design(z)
    n = variables.n_units
    H = np.array(design.H)
    assert design.n_units == n
    for k in range(n):
        low, high = variables.bounds_of(f"H_{k + 1}")
        assert low - 1e-12 <= H[k] <= high + 1e-12
    if variables.heights == "descending":
        assert np.all(np.diff(H) <= 1e-12)
    if case == "gripper":
        assert np.all(np.diff(H[:4]) >= -1e-12)
    if case == "pickplace":
        assert H[4] == H[5]
        np.testing.assert_array_equal(H[:4], [4.0, 4.5, 5.0, 5.0])
        assert design.U_L == (6.0,) * 6 and design.t_lim == 1.0
    if variables.shared_U_L:
        assert len(set(design.U_L)) == 1
    assert variables.contains(DesignBatch.from_designs([design]))[0]


@pytest.mark.parametrize("case", sorted(CASES))
@settings(max_examples=40, deadline=None)
@given(data=hs.data())
def test_encode_inverts_the_map(case, data):
    variables = DesignVariables(**CASES[case])
    # Stay off the degenerate points where a chain interval has zero width.
    z = np.clip(_z(variables, data), 0.02, 0.98)
    batch = variables.designs(z[None, :])
    back, inside = variables.encode(batch)
    assert inside[0]
    np.testing.assert_allclose(back[0], z, atol=1e-9)


@pytest.mark.parametrize("case", sorted(CASES))
def test_jacobian_equals_central_differences(case):
    variables = DesignVariables(**CASES[case])
    rng = np.random.default_rng(3)
    z = rng.uniform(0.1, 0.9, size=(4, variables.n_variables))
    jac = variables.jacobian(z)
    n = variables.n_units
    assert jac.shape == (4, 3 * n + 3, variables.n_variables)

    def params(zz):
        b = variables.designs(zz)
        return np.hstack(
            [b.H[:, :n], b.U_L[:, :n], b.U_sep[:, :n], b.t[:, None], b.t_lim[:, None], b.E[:, None]]
        )

    eps = 1e-6
    for j in range(variables.n_variables):
        step = np.zeros(variables.n_variables)
        step[j] = eps
        fd = (params(z + step) - params(z - step)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, j], fd, atol=1e-8)


def test_names_and_parameter_order():
    variables = DesignVariables(**PICKPLACE)
    assert variables.names == ("H_5=6", "t")
    assert variables.parameters == parameter_names(6)
    assert parameter_names(2) == (
        "H_1",
        "H_2",
        "U_L_1",
        "U_L_2",
        "U_sep_1",
        "U_sep_2",
        "t",
        "t_lim",
        "E",
    )
    assert DesignVariables(n_units=3, shared_U_L=False).names == (
        "H_1",
        "H_2",
        "H_3",
        "U_L_1",
        "U_L_2",
        "U_L_3",
        "U_sep",
        "t",
        "t_lim",
    )


def test_contains_rejects_designs_that_break_a_constraint():
    variables = DesignVariables(n_units=3, heights="descending")
    good = Design(H=[4.5, 4.0, 3.5], U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.5)
    rising = good.replace(H=[3.5, 4.0, 4.5])
    unequal = good.replace(U_L=[7.0, 7.5, 7.0])
    outside = good.replace(t=1.2)
    other_n = Design(H=[4.5, 4.0], U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.5)
    other_E = good.replace(E=12.0)
    inside = variables.contains(
        DesignBatch.from_designs([good, rising, unequal, outside, other_n, other_E])
    )
    np.testing.assert_array_equal(inside, [True, False, False, False, False, False])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(n_units=0), "n_units"),
        (dict(n_units=3, heights="up"), "heights"),
        (dict(n_units=3, H=[3.0, 4.0, 4.5, 5.0]), "H ="),
        (dict(n_units=3, H=[3.0, "4"]), "H"),
        (dict(n_units=3, t=(1.0, 0.5)), "t ="),
        (dict(n_units=3, tied=[(1, 4)]), "tied"),
        (dict(n_units=3, tied=[(1, 2), (2, 3)]), "tied"),
        (dict(n_units=2, H=[(4.0, 5.0), (3.0, 3.5)], heights="ascending"), "no ascending design"),
        (dict(n_units=3, heights="ascending", ordered_units=(2, 1)), "ordered_units"),
    ],
)
def test_bad_variables_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        DesignVariables(**kwargs)


def test_z_outside_the_box_is_refused():
    variables = DesignVariables(n_units=2)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        variables.designs(np.full((1, variables.n_variables), 1.5))


@pytest.mark.parametrize("heights", ["ascending", "descending"])
@settings(max_examples=40, deadline=None)
@given(data=hs.data())
def test_minimum_step_between_ordered_heights_holds_everywhere(heights, data):
    variables = DesignVariables(
        n_units=5,
        heights=heights,
        ordered_units=(1, 2, 3, 4),
        min_step=0.4,
        H=[(3.0, 5.0)] * 4 + [(2.0, 3.0)],
    )
    z = _z(variables, data)
    H = np.array(variables.design(z).H)
    steps = np.diff(H[:4]) * (1 if heights == "ascending" else -1)
    assert np.all(steps >= 0.4 - 1e-12)
    assert np.all((H[:4] >= 3.0 - 1e-12) & (H[:4] <= 5.0 + 1e-12))
    batch = DesignBatch.from_designs([variables.design(z)])
    back, inside = variables.encode(batch)
    assert inside[0]
    np.testing.assert_allclose(variables.design(back[0]).H, H, atol=1e-9)


def test_minimum_step_too_large_for_the_bounds_is_rejected():
    with pytest.raises(ValueError, match="heights"):
        DesignVariables(n_units=4, heights="ascending", min_step=0.7, H=(3.0, 5.0))
