"""Sample plans: stratification, constraints, chunk invariance, reproducibility, memory."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from scipy import stats
from scipy.stats import qmc
from sweep_helpers import make_job

from dpfexplore.sweep import sampling
from dpfexplore.sweep.sampling import (
    order_heights,
    plan_dimensions,
    sample_designs,
    unit_cube_sample,
)


def assert_stratified(points: np.ndarray) -> None:
    """Every column has exactly one point in each of the n strata [i/n, (i+1)/n) (SciPy's
    TestLHS.test_sample_stratified criterion)."""
    n = points.shape[0]
    strata = np.floor(points * n).astype(int)
    expected = np.arange(n)
    for j in range(points.shape[1]):
        np.testing.assert_array_equal(np.sort(strata[:, j]), expected)


def test_lhs_plan_is_stratified_and_in_the_cube():
    points = unit_cube_sample("lhs", 3, 5, 1500, 17, 0, 1500)
    assert points.shape == (1500, 17)
    assert points.min() >= 0.0 and points.max() < 1.0
    assert_stratified(points)


def test_lhs_plan_is_scipys_latin_hypercube():
    # The plan of one block is exactly SciPy's LatinHypercube with the documented seeding.
    rng = np.random.default_rng(np.random.SeedSequence(11, spawn_key=(4, 0)))
    expected = qmc.LatinHypercube(6, scramble=True, rng=rng).random(300)
    np.testing.assert_array_equal(unit_cube_sample("lhs", 11, 4, 300, 6, 0, 300), expected)


def test_large_plans_are_replicated_latin_hypercubes(monkeypatch):
    monkeypatch.setattr(sampling, "LHS_BLOCK", 64)
    sampling._lhs_block.cache_clear()
    n = 64 * 3 + 29
    points = unit_cube_sample("lhs", 0, 3, n, 5, 0, n)
    for block in range(3):
        assert_stratified(points[64 * block : 64 * (block + 1)])
    assert_stratified(points[192:])  # the last, shorter block on its own strata
    # Pooled, every 1/64 stratum of every dimension holds 3 points of the full blocks.
    counts = np.stack(
        [np.bincount(np.floor(points[:192, j] * 64).astype(int), minlength=64) for j in range(5)]
    )
    assert np.all(counts == 3)
    sampling._lhs_block.cache_clear()


@pytest.mark.parametrize("sampler", ["lhs", "sobol"])
def test_chunks_equal_the_whole_plan(sampler, monkeypatch):
    monkeypatch.setattr(sampling, "LHS_BLOCK", 50)  # chunks straddle block boundaries
    sampling._lhs_block.cache_clear()
    n, d = 256, 7
    whole = unit_cube_sample(sampler, 5, 6, n, d, 0, n)
    for size in (1, 7, 33, 100, 256):
        pieces = [
            unit_cube_sample(sampler, 5, 6, n, d, s, min(s + size, n)) for s in range(0, n, size)
        ]
        np.testing.assert_array_equal(np.concatenate(pieces), whole)
    # and in any order (the cache must not leak state between chunks)
    np.testing.assert_array_equal(unit_cube_sample(sampler, 5, 6, n, d, 120, 130), whole[120:130])
    np.testing.assert_array_equal(unit_cube_sample(sampler, 5, 6, n, d, 3, 9), whole[3:9])
    sampling._lhs_block.cache_clear()


def test_sobol_plan_is_one_scrambled_sobol_sequence():
    rng = np.random.default_rng(np.random.SeedSequence(2, spawn_key=(3,)))
    expected = qmc.Sobol(4, scramble=True, rng=rng).random_base2(7)
    np.testing.assert_array_equal(unit_cube_sample("sobol", 2, 3, 128, 4, 0, 128), expected)
    np.testing.assert_array_equal(
        unit_cube_sample("sobol", 2, 3, 128, 4, 64, 100), expected[64:100]
    )


def test_reproducible_from_seed_and_seed_zero_is_a_seed():
    a = unit_cube_sample("lhs", 0, 3, 100, 4, 0, 100)
    np.testing.assert_array_equal(a, unit_cube_sample("lhs", 0, 3, 100, 4, 0, 100))
    assert not np.array_equal(a, unit_cube_sample("lhs", 1, 3, 100, 4, 0, 100))
    # each N has its own stream
    assert not np.array_equal(a, unit_cube_sample("lhs", 0, 4, 100, 4, 0, 100))


def test_plan_dimensions_follow_constraints():
    free = make_job()
    labels = [d.label for d in plan_dimensions(free.space, 3)]
    assert labels == [
        "H_1",
        "H_2",
        "H_3",
        "U_L_1",
        "U_L_2",
        "U_L_3",
        "U_sep_1",
        "U_sep_2",
        "U_sep_3",
        "t",
        "t_lim",
    ]
    equal = make_job(
        **{
            "space.constraints.equal_U_sep": True,
            "space.constraints.equal_U_L": True,
            "space.variables.t": 0.8,
        }
    )
    labels = [d.label for d in plan_dimensions(equal.space, 3)]
    assert labels == ["H_1", "H_2", "H_3", "U_L", "U_sep", "t_lim"]


def test_designs_respect_bounds_fixed_values_and_equal_constraints():
    spec = make_job(
        **{
            "space.constraints.equal_U_sep": True,
            "space.variables.t": 0.8,
            "job.samples_per_n": 200,
        }
    )
    batch = sample_designs(spec, 3, 0, 200)
    assert len(batch) == 200 and np.all(batch.n_units == 3)
    assert np.all((batch.H[:, :3] >= 3.0) & (batch.H[:, :3] <= 5.0))
    assert np.all(np.isnan(batch.H[:, 3:]))
    assert np.all(batch.t == 0.8) and np.all(batch.E == 26.0)
    np.testing.assert_array_equal(batch.U_sep[:, 1], batch.U_sep[:, 0])
    np.testing.assert_array_equal(batch.U_sep[:, 2], batch.U_sep[:, 0])
    # the shared U_sep is one stratified dimension
    assert_stratified(((batch.U_sep[:, :1] - 1.0) / 4.0).clip(0, 1 - 1e-12))
    assert np.all(batch.status() == 0)


@pytest.mark.parametrize("order", ["ascending", "descending"])
def test_ordered_heights_are_uniform_on_the_ordered_region(order):
    n_units, n = 4, 4000
    u = unit_cube_sample("lhs", 9, n_units, n, n_units, 0, n)
    y = order_heights(u, order)
    steps = np.diff(y, axis=1)
    assert np.all(steps >= 0) if order == "ascending" else np.all(steps <= 0)
    assert y.min() >= 0.0 and y.max() <= 1.0
    ranks = np.arange(1, n_units + 1) if order == "ascending" else np.arange(n_units, 0, -1)
    for k, rank in enumerate(ranks):
        # the k-th height of a uniform point of the ordered region is the rank-th order
        # statistic of n_units uniforms: Beta(rank, n_units + 1 - rank)
        result = stats.kstest(y[:, k], stats.beta(rank, n_units + 1 - rank).cdf)
        assert result.pvalue > 1e-3, (k, result)
    # Unit 1 is stratified in the quantiles of its own marginal law.
    marginal = stats.beta(ranks[0], n_units + 1 - ranks[0]).cdf(y[:, 0])
    assert_stratified(marginal[:, None].clip(0, 1 - 1e-12))


def test_sorting_would_lose_the_strata_the_transform_keeps():
    # Why the Rosenblatt map and not a sort: sorting leaves unit 1's quantiles unstratified.
    u = unit_cube_sample("lhs", 1, 3, 600, 3, 0, 600)
    sorted_first = np.sort(u, axis=1)[:, 0]
    quantiles = stats.beta(1, 3).cdf(sorted_first)
    counts = np.bincount(np.floor(quantiles * 600).astype(int), minlength=600)
    assert counts.max() > 1
    mapped = stats.beta(1, 3).cdf(order_heights(u, "ascending")[:, 0])
    assert np.all(np.bincount(np.floor(mapped * 600).astype(int), minlength=600) == 1)


def test_ordered_heights_in_designs():
    spec = make_job(**{"space.constraints.heights": "descending", "job.samples_per_n": 300})
    batch = sample_designs(spec, 3, 0, 300)
    assert np.all(np.diff(batch.H[:, :3], axis=1) <= 0)
    assert np.all((batch.H[:, :3] >= 3.0) & (batch.H[:, :3] <= 5.0))


def test_chunk_memory_does_not_grow_with_the_plan():
    # A chunk of a 10^7-design plan costs what a chunk of a 2*10^5-design plan costs.
    def peak(n_samples):
        sampling._lhs_block.cache_clear()
        tracemalloc.start()
        start = 2 * sampling.LHS_BLOCK + 100  # inside a full block of both plans
        unit_cube_sample("lhs", 0, 5, n_samples, 20, start, start + 2000)
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top

    small, large = peak(200_000), peak(10_000_000)
    sampling._lhs_block.cache_clear()
    block_bytes = sampling.LHS_BLOCK * 20 * 8
    assert large < 1.2 * small
    assert large < 6 * block_bytes  # one block and SciPy's temporaries, nothing O(n)
