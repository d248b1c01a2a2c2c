"""Right-hand side, Jacobians, damping matrix and banded LU of the dynamics kernels."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GRIPPER, PICKPLACE, read_reference
from hypothesis import given, settings
from hypothesis import strategies as hs

from dpfexplore._kernels.dynamics import motion as kd
from dpfexplore._kernels.dynamics.batch import rest_state
from dpfexplore._kernels.dynamics.explicit import DP_A, DP_B, DP_C, DP_E
from dpfexplore._kernels.dynamics.rosenbrock import (
    RODAS4_A,
    RODAS4_ALPHA,
    RODAS4_B,
    RODAS4_C,
    RODAS4_GAMMA,
    RODAS4_GAMMA_SUM,
)
from dpfexplore._kernels.linalg.banded_lu import LATTICE_HALF_BANDWIDTH, lu_factor, lu_solve
from dpfexplore._kernels.linalg.cholesky import band_matvec_add
from dpfexplore._kernels.records import MotionModel, MotionScratch
from dpfexplore.model.design import Design
from dpfexplore.solvers.dynamics.simulate import PressureProfile
from dpfexplore.solvers.lattice import lattice_params

DESIGNS = {1: Design(**PICKPLACE), 2: Design(**GRIPPER)}


def _scratch(n_units):
    n = 4 * n_units - 2
    nodes = 2 * n_units + 2
    return MotionScratch(np.empty((nodes, 2)), np.empty((nodes, 2)), np.empty(n))


def _phys(n_units, eta=kd.ETA_INTERNAL, eta_iso=kd.ETA_ISO):
    return np.array([eta, eta_iso, kd.node_mass(n_units)])


def test_rhs_matches_seed_implementation():
    """Accelerations at every point of reference/rhs.csv (all pressure phases) to 1e-12."""
    ref = read_reference("rhs.csv")
    checked = set()
    for (design_id, _sample), group in ref.groupby(["design", "sample"]):
        design = DESIGNS[design_id]
        params = lattice_params(design)
        n_units = design.n_units
        x = np.column_stack([group.x, group.y]).ravel()
        v = np.column_stack([group.vx, group.vy]).ravel()
        expected = np.column_stack([group.ax, group.ay]).ravel()
        row = group.iloc[0]
        knot_t = np.array([row.tau1, row.tau2, row.tau3, row.tau4], dtype=float)
        knot_p = np.array([0.0, row.P0, row.P0, 0.0])
        pos, vel, work = _scratch(n_units)
        acc = np.empty_like(x)
        pressure = kd.acceleration(
            x,
            v,
            float(row.t),
            MotionModel(params.unit_params, params.h, knot_t, knot_p, _phys(n_units)),
            MotionScratch(pos, vel, work),
            acc,
        )
        checked.add(round(pressure / row.P0, 6))
        scale = np.abs(expected).max()
        np.testing.assert_allclose(acc, expected, rtol=0, atol=1e-12 * scale)
        # and component-wise wherever the acceleration is not tiny against the largest one
        big = np.abs(expected) > 1e-3 * scale
        np.testing.assert_allclose(acc[big], expected[big], rtol=1e-12)
    assert checked == {0.5, 1.0, 0.0}  # ramp, hold, release ramp (0.5) and released


def _pulse_case(design, t):
    """A random state of ``design`` at time ``t`` (s) of the paper's pulse (0.7 MPa at τ = 0, 1,
    5, 5.1 s): lattice parameters, positions, velocities, knot times, pressures and ``phys``."""
    params, x, v = _random_state(design, seed=int(10 * t))
    knot_t, knot_p = np.array([0.0, 1.0, 5.0, 5.1]), np.array([0.0, 0.7, 0.7, 0.0])
    return params, x, v, knot_t, knot_p, _phys(design.n_units)


def _random_state(design, seed, spread=0.4, speed=30.0):
    params = lattice_params(design)
    n = 4 * design.n_units - 2
    y = np.empty(2 * n)
    rest_state(params.unit_params, params.h, y)
    rng = np.random.default_rng(seed)
    return params, y[:n] + rng.normal(0, spread, n), rng.normal(0, speed, n)


@pytest.mark.parametrize("t", [0.5, 2.0, 5.05, 8.0])
def test_full_jacobian_against_central_differences(t):
    design = DESIGNS[2]
    params, x, v, knot_t, knot_p, phys = _pulse_case(design, t)
    n = x.size
    pos, vel, work = _scratch(design.n_units)
    jac = np.empty((2 * n, 2 * n))
    kd.full_jacobian(
        x,
        v,
        t,
        MotionModel(params.unit_params, params.h, knot_t, knot_p, phys),
        MotionScratch(pos, vel, work),
        np.empty((n, n)),
        jac,
    )

    def f(y):
        acc = np.empty(n)
        kd.acceleration(
            y[:n],
            y[n:],
            t,
            MotionModel(params.unit_params, params.h, knot_t, knot_p, phys),
            MotionScratch(pos, vel, work),
            acc,
        )
        return np.concatenate([y[n:], acc])

    y = np.concatenate([x, v])
    fd = np.empty_like(jac)
    for j in range(2 * n):
        step = 1e-6 * max(1.0, abs(y[j]))
        e = np.zeros(2 * n)
        e[j] = step
        fd[:, j] = (f(y + e) - f(y - e)) / (2 * step)
    assert np.abs(jac - fd).max() <= 1e-7 * np.abs(jac).max()


@pytest.mark.parametrize("t", [0.5, 3.0, 8.0])
def test_fused_residual_and_jacobian_equal_the_separate_kernels(t):
    """Rodas4's first stage and its Jacobian come from one pass; they must be the same numbers."""
    design = DESIGNS[1]
    params, x, v, knot_t, knot_p, phys = _pulse_case(design, t)
    n = x.size
    model = MotionModel(params.unit_params, params.h, knot_t, knot_p, phys)
    res, jac = np.empty(n), np.empty((n, n))
    p_fused = kd.residual_and_jacobian(x, v, t, model, _scratch(design.n_units), res, jac)
    res_alone, jac_alone = np.empty(n), np.empty((n, n))
    p_alone = kd.force_residual(x, v, t, model, _scratch(design.n_units), res_alone)
    kd.stiffness_jacobian(x, v, t, model, _scratch(design.n_units), jac_alone)
    assert p_fused == p_alone == kd.pressure_at(t, knot_t, knot_p)
    np.testing.assert_array_equal(res, res_alone)
    np.testing.assert_array_equal(jac, jac_alone)


def test_damping_is_linear_in_velocity_with_symmetric_matrix():
    """``F_damp(x, v) = (C - η_iso I) v`` exactly; ``C`` symmetric (a dashpot per spring)."""
    design = DESIGNS[1]
    params, x, v = _random_state(design, seed=3)
    n = x.size
    pos, vel, work = _scratch(design.n_units)
    from dpfexplore._kernels.lattice import unpack_nodes

    unpack_nodes(x, params.unit_params, params.h, pos)
    cmat = np.empty((n, n))
    kd.damping_matrix(pos, params.unit_params, params.h, 0.05, 0.01, work, cmat)
    kd.node_velocities(v, design.n_units, vel)
    force = np.zeros(n)
    kd.add_damping_forces(pos, vel, params.unit_params, params.h, 0.05, force)
    np.testing.assert_allclose(force + 0.01 * v, cmat @ v, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(cmat, cmat.T)


def test_pressure_forces_are_linear_in_positions():
    """``F_ext(x) = P A x`` for a constant matrix ``A``: its Jacobian reproduces it exactly."""
    design = DESIGNS[2]
    params, x, _ = _random_state(design, seed=4)
    n = x.size
    from dpfexplore._kernels.lattice import unpack_nodes

    pos = np.empty((2 * design.n_units + 2, 2))
    unpack_nodes(x, params.unit_params, params.h, pos)
    force = np.zeros(n)
    kd.add_pressure_forces(pos, design.n_units, 0.3, force)
    jac = np.zeros((n, n))
    kd.add_pressure_jacobian(design.n_units, 0.3, jac)
    # the clamped nodes contribute a constant; recover it at x = 0 of the free nodes
    pos0 = pos.copy()
    zero = np.zeros(n)
    unpack_nodes(zero, params.unit_params, params.h, pos0)
    base = np.zeros(n)
    kd.add_pressure_forces(pos0, design.n_units, 0.3, base)
    np.testing.assert_allclose(force, base + jac @ x, rtol=1e-12, atol=1e-12)


def test_pressure_faces_on_flat_finger():
    """Flat finger at 1 MPa: layer pushed up, dome line down, posts toward the tip.

    On the flat finger every face is axis-aligned, so the loads are the face lengths:
    ``D_1`` gets half the first dome face down and half its post toward the tip.
    """
    design = Design(H=[4.0, 4.0], U_L=6.0, U_sep=1.0, t=0.8, t_lim=1.0)
    params = lattice_params(design)
    pos = np.empty((6, 2))
    from dpfexplore._kernels.lattice import rest_nodes

    rest_nodes(params.unit_params, params.h, pos)
    force = np.zeros(6)
    kd.add_pressure_forces(pos, 2, 1.0, force)
    p, h = params.unit_params[0, 0], params.h
    # D1: half of dome 1 and dome 2 down, half of post 1 toward the tip
    np.testing.assert_allclose(force[0:2], [h / 2, -p])
    # D2 (tip dome node): half of dome 2 down, half of post 2 toward the tip
    np.testing.assert_allclose(force[2:4], [h / 2, -p / 2])
    # L2: half of layer 2 up, half of post 2 toward the tip
    np.testing.assert_allclose(force[4:6], [h / 2, p / 2])


def test_pressure_profile_shapes():
    profile = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
    np.testing.assert_allclose(
        profile([-1, 0, 0.5, 1, 3, 5, 5.05, 5.1, 9]), [0, 0, 0.35, 0.7, 0.7, 0.7, 0.35, 0, 0]
    )
    assert profile.t_release == 5.1
    assert PressureProfile(P0=0.7, tau=(0.0, 1.0, 5.0, 5.1)) == profile
    assert PressureProfile.parse("0:0, 1:0.7, 5:0.7, 5.1:0") == profile
    knot_t, knot_p = profile.knots()
    for t in np.linspace(-1, 7, 81):
        assert kd.pressure_at(t, knot_t, knot_p) == pytest.approx(float(profile(t)), abs=1e-15)
    two = PressureProfile.pulses([(0.7, 0, 1, 2, 2.1), (0.5, 3, 3.5, 4, 4.1)])
    assert two.t_release == 4.1
    assert float(two(2.5)) == 0.0 and float(two(3.75)) == 0.5


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(times=(0, 2, 1), pressures=(0, 1, 0)), "times"),
        (dict(times=(0, 1), pressures=(0,)), "pressures"),
        (dict(times=(0, float("nan")), pressures=(0, 1)), "times"),
        (dict(P0=0.7, tau=(0, 2, 1, 3)), "tau"),
        (dict(P0=float("inf"), tau=(0, 1, 2, 3)), "P0"),
    ],
)
def test_pressure_profile_rejects_bad_input(kwargs, field):
    with pytest.raises(ValueError, match=field):
        PressureProfile(**kwargs)


def _banded(rng, n, band):
    a = rng.normal(size=(n, n))
    a[np.abs(np.subtract.outer(np.arange(n), np.arange(n))) > band] = 0.0
    return a


@settings(max_examples=40, deadline=None)
@given(n=hs.integers(1, 46), band=hs.integers(0, 10), seed=hs.integers(0, 2**31))
def test_banded_lu_solves_like_numpy(n, band, seed):
    """Threshold pivoting inside the band: random matrices swap rows, ``U`` grows to 2x band."""
    rng = np.random.default_rng(seed)
    band = min(band, n - 1)
    a = _banded(rng, n, band) + 1e-3 * np.eye(n)
    b = rng.normal(size=n)
    factors = a.copy()
    piv = np.empty(n, dtype=np.int64)
    if lu_factor(factors, n, piv, band) != 0:
        return  # exactly singular draw
    z = b.copy()
    lu_solve(factors, n, piv, z, band)
    expected = np.linalg.solve(a, b)
    cond = np.linalg.cond(a)
    assert np.abs(z - expected).max() <= 1e-12 * cond * max(1.0, np.abs(expected).max())


def test_lu_keeps_the_diagonal_pivot_unless_it_is_below_the_threshold():
    """A diagonal pivot at least 0.1 of its column's largest entry stays; a smaller one swaps."""
    rng = np.random.default_rng(7)
    n, band = 22, LATTICE_HALF_BANDWIDTH
    a = _banded(rng, n, band) + 20.0 * np.eye(n)
    a[9, 8] = 60.0  # larger than the diagonal, which still passes the threshold
    b = rng.normal(size=n)
    for small_at in (None, 5):
        m = a.copy()
        if small_at is not None:  # a zero diagonal entry with a large one below it
            m[small_at, small_at] = 0.0
            m[small_at + 1, small_at] = 10.0
        factors = m.copy()
        piv = np.empty(n, dtype=np.int64)
        assert lu_factor(factors, n, piv, band) == 0
        swapped = np.flatnonzero(piv != np.arange(n))
        if small_at is None:
            assert swapped.size == 0
        else:
            assert small_at in swapped
        z = b.copy()
        lu_solve(factors, n, piv, z, band)
        expected = np.linalg.solve(m, b)
        assert np.abs(z - expected).max() <= 1e-13 * np.linalg.cond(m) * np.abs(expected).max()


@settings(max_examples=30, deadline=None)
@given(n=hs.integers(1, 46), band=hs.integers(0, 10), seed=hs.integers(0, 2**31))
def test_band_product_adds_the_matrix_vector_product(n, band, seed):
    rng = np.random.default_rng(seed)
    band = min(band, n - 1)
    a = _banded(rng, n, band)
    x = rng.normal(size=n)
    out = rng.normal(size=n)
    expected = out + a @ x
    band_matvec_add(a, x, n, band, out)
    np.testing.assert_allclose(out, expected, rtol=1e-13, atol=1e-13 * np.abs(a).sum(axis=1).max())


def test_lu_reports_singular_matrix():
    a = np.zeros((4, 4))
    assert lu_factor(a, 4, np.empty(4, dtype=np.int64), 3) == 1


def test_stage_matrix_is_within_the_lattice_band():
    """Every matrix the integrators factor vanishes outside the half-bandwidth (N = 12)."""
    design = Design(H=[4.0, 3.0] * 6, U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    params, x, v = _random_state(design, seed=5)
    n = x.size
    pos, vel, work = _scratch(design.n_units)
    stiff = np.empty((n, n))
    knot = np.array([0.0])
    kd.stiffness_jacobian(
        x,
        v,
        0.0,
        MotionModel(params.unit_params, params.h, knot, np.array([0.7]), _phys(12)),
        MotionScratch(pos, vel, work),
        stiff,
    )
    cmat = np.empty((n, n))
    kd.damping_matrix(pos, params.unit_params, params.h, 0.05, 0.01, work, cmat)
    outside = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) > LATTICE_HALF_BANDWIDTH
    assert np.all(stiff[outside] == 0.0) and np.all(cmat[outside] == 0.0)
    assert np.any(
        stiff[
            ~outside
            & (np.abs(np.subtract.outer(np.arange(n), np.arange(n))) == LATTICE_HALF_BANDWIDTH)
        ]
        != 0.0
    )


def _order(errors, steps):
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


def _rodas_step(f, jac, y, h):
    """One Rodas4 step of ``y' = f(y)`` from the coefficient tables (NumPy reference)."""
    n = y.size
    w = np.eye(n) / (h * RODAS4_GAMMA) - jac(y)
    k = np.zeros((6, n))
    for s in range(6):
        ys = y + RODAS4_A[s, :s] @ k[:s]
        k[s] = np.linalg.solve(w, f(ys) + RODAS4_C[s, :s] @ k[:s] / h)
    return y + RODAS4_B @ k, k[5]


def test_rodas4_tableau_has_order_four_with_order_three_estimate():
    """Fixed-step convergence on a non-linear, non-stiff problem (Lotka–Volterra)."""

    def f(y):
        return np.array([y[0] * (1.0 - y[1]), y[1] * (y[0] - 1.0)])

    def jac(y):
        return np.array([[1.0 - y[1], -y[0]], [y[1], y[0] - 1.0]])

    assert RODAS4_ALPHA[0] == 0.0 and RODAS4_GAMMA_SUM[0] == RODAS4_GAMMA
    y0 = np.array([2.0, 0.5])
    exact = None
    steps = np.array([16, 32, 64, 128])
    finals = []
    local = []
    for m in [*steps, 2048]:
        y = y0.copy()
        h = 1.0 / m
        for _ in range(m):
            y, est = _rodas_step(f, jac, y, h)
        finals.append(y)
        _, est = _rodas_step(f, jac, y0, h)
        local.append(np.linalg.norm(est))
    exact = finals[-1]
    global_err = [np.linalg.norm(y - exact) for y in finals[:-1]]
    assert _order(global_err, steps) == pytest.approx(-4.0, abs=0.25)
    # the embedded estimate is the local error of the order-3 solution: O(h^4)
    assert _order(local[:-1], steps) == pytest.approx(-4.0, abs=0.3)


def test_dopri5_tableau_has_order_five():
    def f(y):
        return np.array([y[0] * (1.0 - y[1]), y[1] * (y[0] - 1.0)])

    assert np.allclose(DP_A.sum(axis=1), DP_C)
    assert DP_B.sum() == pytest.approx(1.0) and DP_E.sum() == pytest.approx(0.0, abs=1e-15)
    y0 = np.array([2.0, 0.5])
    steps = np.array([16, 32, 64])  # pre-asymptotic below 16, round-off above 64
    finals = []
    for m in [*steps, 1024]:
        y = y0.copy()
        h = 1.0 / m
        for _ in range(m):
            k = np.zeros((7, 2))
            for s in range(7):
                k[s] = f(y + h * DP_A[s, :s] @ k[:s])
            y = y + h * DP_B @ k
        finals.append(y)
    errors = [np.linalg.norm(y - finals[-1]) for y in finals[:-1]]
    assert _order(errors, steps) == pytest.approx(-5.0, abs=0.3)
