"""The shell kernels against oracles: finite differences, NumPy's solve and eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore._kernels.linalg.band_storage import band_lu, band_lu_solve, negative_pivots
from dpfexplore._kernels.shell.energy import BAND, assemble
from dpfexplore.unitcell.geometry import reference_unknowns, shell


def _dense(band: np.ndarray) -> np.ndarray:
    m = band.shape[0]
    dense = np.zeros((m, m))
    for i in range(m):
        for k in range(-BAND, BAND + 1):
            if 0 <= i + k < m:
                dense[i, i + k] = band[i, BAND + k]
    return dense


def _energy(y, geom) -> float:
    membrane, bending = assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)
    return membrane + bending


def _derivatives(y, geom):
    m = y.size
    grad, band = np.zeros(m), np.zeros((m, 2 * BAND + 1))
    assemble(y, geom, grad, band, 2)
    return grad, _dense(band)


def _deformed(geom, rng, scale):
    y = reference_unknowns(geom)
    y = y + scale * rng.standard_normal(y.size)
    y[0] = 1.0 + rng.random()  # apex travel: well inside the inversion
    return y


@pytest.mark.parametrize("H, grading", [(3.0, 0.0), (5.0, 0.5), (0.0, 0.0)])
def test_gradient_and_hessian_match_central_differences(H, grading):
    geom = shell(H, 0.7, 5.0, 26.0, 0.35, 10, grading)
    rng = np.random.default_rng(21)
    for _ in range(3):
        y = _deformed(geom, rng, 0.2)
        grad, hess = _derivatives(y, geom)
        h = 1e-5
        eye = np.eye(y.size)
        grad_fd = np.array(
            [(_energy(y + h * e, geom) - _energy(y - h * e, geom)) / (2 * h) for e in eye]
        )
        hess_fd = np.array(
            [
                (_derivatives(y + h * e, geom)[0] - _derivatives(y - h * e, geom)[0]) / (2 * h)
                for e in eye
            ]
        )
        assert np.max(np.abs(grad - grad_fd)) <= 1e-6 * np.max(np.abs(grad))
        assert np.max(np.abs(hess - hess_fd)) <= 1e-6 * np.max(np.abs(hess))
        assert np.max(np.abs(hess - hess.T)) <= 1e-12 * np.max(np.abs(hess))


def test_reference_state_is_strain_free():
    geom = shell(4.0, 0.8, 5.0, 26.0, 0.35, 40)
    y = reference_unknowns(geom)
    grad, _ = _derivatives(y, geom)
    assert _energy(y, geom) < 1e-20
    # round-off only: the angles are recomputed from the node coordinates
    assert np.max(np.abs(grad)) < 1e-12 * geom.C * 5.0


def test_a_uniform_radial_stretch_costs_membrane_energy():
    geom = shell(3.0, 0.8, 5.0, 26.0, 0.35, 20)
    y = reference_unknowns(geom)
    y[1::2] *= 1.01
    membrane, bending = assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)
    assert membrane > 0.0 and bending >= 0.0


def test_band_lu_solves_like_numpy():
    rng = np.random.default_rng(3)
    m, kl, ku = 30, 5, 6
    dense = np.zeros((m, m))
    for i in range(m):
        for j in range(max(0, i - kl), min(m, i + ku + 1)):
            dense[i, j] = rng.standard_normal()
    w = np.zeros((m, 2 * kl + ku + 1))
    for i in range(m):
        for j in range(max(0, i - kl), min(m, i + ku + 1)):
            w[i, j - i + kl] = dense[i, j]
    piv = np.zeros(m, dtype=np.int64)
    assert band_lu(w, m, kl, ku, piv) == 0
    b = rng.standard_normal(m)
    x = b.copy()
    band_lu_solve(w, m, kl, ku, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(dense, b), rtol=1e-9, atol=1e-12)


def test_negative_pivots_count_negative_eigenvalues():
    geom = shell(3.0, 0.6, 5.0, 26.0, 0.35, 16)
    rng = np.random.default_rng(5)
    for _ in range(4):
        y = _deformed(geom, rng, 0.3)
        grad, band = np.zeros(y.size), np.zeros((y.size, 2 * BAND + 1))
        assemble(y, geom, grad, band, 2)
        for lo in (0, 1):
            expected = int(np.sum(np.linalg.eigvalsh(_dense(band)[lo:, lo:]) < 0.0))
            assert negative_pivots(band, lo, BAND, np.zeros_like(band)) == expected
