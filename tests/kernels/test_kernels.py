"""Energy, gradient and Hessian kernels against the seed implementation, finite differences and
an independent NumPy implementation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import design_from_row, free_coordinates, read_reference
from hypothesis import given, settings
from hypothesis import strategies as hs

from dpfexplore._kernels.lattice import (
    HESSIAN_CONVEX,
    assemble,
    lattice_energy,
    lattice_energy_split,
    lattice_gradient,
    lattice_hessian,
)
from dpfexplore._kernels.linalg.cholesky import (
    block_size,
    block_start,
    cholesky,
    cholesky_solve,
    n_blocks,
)
from dpfexplore._kernels.statics.states import geometric_guess
from dpfexplore.bench.numpy_model import NumpyLattice
from dpfexplore.model.design import Design
from dpfexplore.solvers.lattice import lattice_params

REFERENCE = read_reference("energy_gradient.csv")
SAMPLES = sorted(REFERENCE.groupby(["design", "sample"]).groups)


def energy(x, p):
    return lattice_energy(x, p.unit_params, p.h)


def gradient(x, p):
    g = np.empty_like(x)
    lattice_gradient(x, p.unit_params, p.h, g)
    return g


def hessian(x, p):
    g = np.empty_like(x)
    hm = np.empty((x.size, x.size))
    lattice_hessian(x, p.unit_params, p.h, g, hm)
    return hm


def central_gradient(x, p, step=1e-6):
    out = np.empty_like(x)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = step
        out[i] = (energy(x + e, p) - energy(x - e, p)) / (2 * step)
    return out


def central_hessian(x, p, step=1e-6):
    out = np.empty((x.size, x.size))
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = step
        out[:, i] = (gradient(x + e, p) - gradient(x - e, p)) / (2 * step)
    return out


@pytest.mark.parametrize(("design_id", "sample"), SAMPLES)
def test_energy_and_gradient_reproduce_the_seed_implementation(design_id, sample):
    rows = REFERENCE[(REFERENCE.design == design_id) & (REFERENCE["sample"] == sample)]
    p = lattice_params(design_from_row(rows.iloc[0]))
    x = free_coordinates(rows)
    ref_energy = rows.energy.iloc[0]
    ref_grad = np.ravel(np.column_stack([rows.grad_x, rows.grad_y]))
    assert energy(x, p) == pytest.approx(ref_energy, rel=1e-12)
    g = gradient(x, p)
    # every component to 1e-12 of the gradient's scale (tiny components carry the same
    # absolute round-off as large ones)
    np.testing.assert_allclose(g, ref_grad, rtol=1e-12, atol=1e-12 * np.abs(ref_grad).max())


def check_derivatives(design: Design, x: np.ndarray) -> None:
    p = lattice_params(design)
    g = gradient(x, p)
    fd = central_gradient(x, p)
    scale = max(np.abs(g).max(), 1.0)
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-6 * scale)
    hm = hessian(x, p)
    np.testing.assert_array_equal(hm, hm.T)
    fd_h = central_hessian(x, p)
    np.testing.assert_allclose(hm, fd_h, rtol=1e-5, atol=1e-6 * np.abs(hm).max())


BOX = {
    "H": (3.0, 5.0),
    "U_sep": (1.0, 5.0),
    "U_L": (5.5, 10.0),
    "t": (0.5, 1.0),
    "t_lim": (1.0, 2.0),
}


def perturbed_guess(design: Design, state: int, rng: np.random.Generator, scale: float = 0.3):
    p = lattice_params(design)
    x = np.empty(4 * design.n_units - 2)
    geometric_guess(p.unit_params, p.h, state, 1.0, x)
    return x + rng.normal(scale=scale, size=x.size)


@pytest.mark.parametrize("corner", list(itertools.product((0, 1), repeat=5)))
def test_derivatives_at_every_corner_of_the_paper_box(corner):
    values = {name: BOX[name][c] for name, c in zip(BOX, corner, strict=True)}
    design = Design(
        H=[values["H"]] * 3,
        U_L=values["U_L"],
        U_sep=values["U_sep"],
        t=values["t"],
        t_lim=values["t_lim"],
    )
    rng = np.random.default_rng(sum(c << i for i, c in enumerate(corner)))
    check_derivatives(design, perturbed_guess(design, int(rng.integers(8)), rng))


@settings(max_examples=40, deadline=None)
@given(
    n_units=hs.integers(1, 8),
    unit=hs.lists(
        hs.tuples(*(hs.floats(*BOX[k]) for k in ("H", "U_L", "U_sep"))), min_size=8, max_size=8
    ),
    t=hs.floats(*BOX["t"]),
    t_lim=hs.floats(*BOX["t_lim"]),
    seed=hs.integers(0, 2**32 - 1),
)
def test_derivatives_on_random_designs(n_units, unit, t, t_lim, seed):
    H, U_L, U_sep = (list(v[:n_units]) for v in zip(*unit, strict=True))
    design = Design(H=H, U_L=U_L, U_sep=U_sep, t=t, t_lim=t_lim)
    rng = np.random.default_rng(seed)
    check_derivatives(design, perturbed_guess(design, int(rng.integers(2**n_units)), rng))


@pytest.mark.parametrize(
    "theta", [1e-7, 1e-3, np.pi / 2, np.pi - 1e-3, np.pi - 1e-7, np.pi, np.pi + 1e-3]
)
def test_torsion_terms_are_smooth_near_0_and_pi(theta):
    """The angle L1-L2-D2 set to θ: the implementation's arccos form divides by sin θ there."""
    design = Design(H=[4.0, 4.0], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.5)
    p = lattice_params(design)
    x = np.empty(6)
    geometric_guess(p.unit_params, p.h, 0, 1.0, x)
    layer2 = x[4:6]
    arm = np.array([p.unit_params[0, 0], p.h]) - layer2  # L2 -> L1
    arm /= np.linalg.norm(arm)
    # rotate the arm L2->L1 counter-clockwise by θ: D2 then sits at signed angle θ from it
    c, s = np.cos(theta), np.sin(theta)
    arm_d = np.array([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]])
    x[2:4] = layer2 + p.h * arm_d
    e_split = np.empty(4)
    lattice_energy_split(x, p.unit_params, p.h, e_split)
    # δ = θ - π/2 on that spring (the only torsion spring of a 2-unit finger that D2 touches
    # besides D1-L1-L2, which is at rest here): its energy is ½ k_t (θ - π/2)²
    k_t = p.unit_params[1, 6]
    assert e_split[2] == pytest.approx(0.5 * k_t * (theta - np.pi / 2) ** 2, rel=1e-9, abs=1e-12)
    assert np.all(np.isfinite(gradient(x, p)))
    assert np.all(np.isfinite(hessian(x, p)))
    check_derivatives(design, x)


def test_torsion_energy_passes_smoothly_through_a_straight_angle():
    """Past θ = π the signed angle keeps growing (the unsigned arccos angle would fold back)."""
    design = Design(H=[4.0, 4.0], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.5)
    p = lattice_params(design)
    x = np.empty(6)
    geometric_guess(p.unit_params, p.h, 0, 1.0, x)
    layer1 = np.array([p.unit_params[0, 0], p.h])
    arm = (layer1 - x[4:6]) / np.linalg.norm(layer1 - x[4:6])
    k_t = p.unit_params[1, 6]
    split = np.empty(4)
    for theta in np.pi + np.array([-1e-4, -1e-8, 0.0, 1e-8, 1e-4]):
        c, s = np.cos(theta), np.sin(theta)
        x[2:4] = x[4:6] + p.h * np.array([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]])
        lattice_energy_split(x, p.unit_params, p.h, split)
        assert split[2] == pytest.approx(0.5 * k_t * (theta - np.pi / 2) ** 2, rel=1e-12)


@settings(max_examples=30, deadline=None)
@given(n_units=hs.integers(1, 12), seed=hs.integers(0, 2**32 - 1))
def test_kernels_agree_with_the_independent_numpy_lattice(n_units, seed):
    rng = np.random.default_rng(seed)
    design = Design(
        H=list(rng.uniform(3, 5, n_units)),
        U_L=list(rng.uniform(5.5, 10, n_units)),
        U_sep=list(rng.uniform(1, 5, n_units)),
        t=rng.uniform(0.5, 1.0),
        t_lim=rng.uniform(1, 2),
        E=rng.uniform(5, 40),
    )
    x = perturbed_guess(design, int(rng.integers(2**n_units)), rng)
    p = lattice_params(design)
    e_np, g_np = NumpyLattice.from_params(p.unit_params, p.h).energy_and_gradient(x)
    assert energy(x, p) == pytest.approx(e_np, rel=1e-12)
    np.testing.assert_allclose(gradient(x, p), g_np, rtol=1e-11, atol=1e-11 * np.abs(g_np).max())


def test_energy_split_sums_and_rest_shape_is_free_of_energy():
    design = Design(H=[3.8, 4.2, 4.5], U_L=8.0, U_sep=[1.5, 2.0, 2.5], t=0.8, t_lim=1.2)
    p = lattice_params(design)
    x = np.empty(10)
    geometric_guess(p.unit_params, p.h, 0, 1.0, x)
    split = np.empty(4)
    assert lattice_energy_split(x, p.unit_params, p.h, split) == 0.0
    np.testing.assert_array_equal(gradient(x, p), 0.0)
    geometric_guess(p.unit_params, p.h, 5, 1.0, x)
    total = lattice_energy_split(x, p.unit_params, p.h, split)
    assert total == pytest.approx(split.sum(), rel=1e-15)
    assert split[3] == 0.0  # no steering penalty in physical evaluations
    assert np.all(split[:3] > 0)


def test_energy_and_stiffness_scale_with_E_and_shapes_do_not():
    base = Design(H=[3.8, 4.2, 4.5], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.2, E=10.0)
    x = perturbed_guess(base, 3, np.random.default_rng(0))
    p1 = lattice_params(base)
    p3 = lattice_params(base.replace(E=30.0))
    assert energy(x, p3) == pytest.approx(3 * energy(x, p1), rel=1e-13)
    np.testing.assert_allclose(hessian(x, p3), 3 * hessian(x, p1), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("n_units", [1, 2, 3, 5, 12])
def test_hessian_is_block_tridiagonal_and_the_factor_solves_like_lapack(n_units):
    """The block Cholesky reads only the diagonal and sub-diagonal post blocks: the lattice
    Hessian must vanish outside them (at a random, far-from-rest shape), and the factor must
    solve as LAPACK does, including the entries it never writes (``low`` starts as NaN here)."""
    rng = np.random.default_rng(n_units)
    design = Design(H=list(rng.uniform(3.0, 5.0, n_units)), U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.5)
    p = lattice_params(design)
    x = np.empty(4 * n_units - 2)
    geometric_guess(p.unit_params, p.h, 2**n_units - 1, 1.0, x)
    x += rng.normal(0.0, 0.3, x.size)
    h = hessian(x, p)
    n = x.size
    assert n_blocks(n) == n_units
    assert sum(block_size(b) for b in range(n_units)) == n
    block = np.concatenate([np.full(block_size(b), b) for b in range(n_units)])
    assert all(block_start(b) == np.flatnonzero(block == b)[0] for b in range(n_units))
    outside = np.abs(block[:, None] - block[None, :]) > 1
    assert np.all(h[outside] == 0.0)
    # the pattern is tight: every pair of adjacent blocks is coupled
    assert all(np.any(h[np.ix_(block == b + 1, block == b)] != 0.0) for b in range(n_units - 1))
    spd = h + (abs(np.linalg.eigvalsh(h)[0]) + 1.0) * np.eye(n)  # same pattern, made definite
    low = np.full((n, n), np.nan)
    assert cholesky(spd, 0.0, low, n)
    b = rng.normal(size=n)
    out = np.empty(n)
    cholesky_solve(low, b, out, n)
    expected = np.linalg.solve(spd, b)
    assert np.abs(out - expected).max() <= 1e-10 * np.abs(expected).max()
    # a shift is applied as a multiple of the identity
    assert cholesky(spd, 3.0, low, n)
    cholesky_solve(low, b, out, n)
    expected = np.linalg.solve(spd + 3.0 * np.eye(n), b)
    assert np.abs(out - expected).max() <= 1e-10 * np.abs(expected).max()
    # an indefinite matrix is reported, not factored
    assert not cholesky(spd, -2.0 * np.linalg.eigvalsh(spd)[-1], low, n)


def convexified_hessian(x, p):
    g = np.empty_like(x)
    hm = np.empty((x.size, x.size))
    split = np.empty(4)
    pos = np.empty((x.size // 2 + 3, 2))
    assemble(x, p.unit_params, p.h, pos, g, hm, HESSIAN_CONVEX, split)
    return g, hm


@settings(max_examples=25, deadline=None)
@given(n_units=hs.integers(1, 8), seed=hs.integers(0, 2**32 - 1))
def test_convexified_hessian_is_positive_semidefinite_with_the_true_gradient(n_units, seed):
    """The Newton model where the Hessian is indefinite: every spring's Hessian made positive
    semi-definite, so the sum is too, at shapes far from rest (compressed springs, domes on
    their unstable branch); the gradient is the true one."""
    check_convexified_hessian(n_units, seed)


def check_convexified_hessian(n_units: int, seed: int) -> float:
    """The checks of the test above at one random shape; returns the true Hessian's smallest
    eigenvalue there."""
    rng = np.random.default_rng(seed)
    design = Design(
        H=list(rng.uniform(3, 5, n_units)),
        U_L=float(rng.uniform(5.5, 10)),
        U_sep=float(rng.uniform(1, 5)),
        t=float(rng.uniform(0.5, 1.0)),
        t_lim=float(rng.uniform(1, 2)),
    )
    p = lattice_params(design)
    x = perturbed_guess(design, int(rng.integers(2**n_units)), rng, scale=0.5)
    g, hc = convexified_hessian(x, p)
    np.testing.assert_array_equal(g, gradient(x, p))
    np.testing.assert_array_equal(hc, hc.T)
    w = np.linalg.eigvalsh(hc)
    assert w[0] >= -1e-12 * w[-1]
    # where the true Hessian is indefinite, the convexified one differs from it by at least
    # its most negative eigenvalue (Weyl: hc is positive semi-definite)
    true = hessian(x, p)
    lowest = float(np.linalg.eigvalsh(true)[0])
    assert np.linalg.norm(hc - true, 2) >= -lowest - 1e-12 * w[-1]
    return lowest


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_convexified_hessian_at_shapes_where_the_hessian_is_indefinite(seed):
    """Shapes chosen so that the true Hessian is indefinite: the difference is exercised."""
    assert check_convexified_hessian(3, seed) < 0


def test_convexified_hessian_equals_the_hessian_where_every_spring_is_convex():
    """At the stress-free flat finger every spring sits at its rest length (no geometric
    stiffness) with positive curvature, and every torsion at its rest angle: nothing to
    convexify."""
    design = Design(H=[3.8, 4.2, 4.5], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.2)
    p = lattice_params(design)
    x = np.empty(10)
    geometric_guess(p.unit_params, p.h, 0, 1.0, x)
    _, hc = convexified_hessian(x, p)
    np.testing.assert_allclose(hc, hessian(x, p), rtol=0, atol=1e-12 * np.abs(hc).max())
