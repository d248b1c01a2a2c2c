"""Sample plans of a sweep: Latin hypercube or scrambled Sobol' points, scaled explicitly.

The points live in the unit cube and are mapped onto the design space in one visible step.

A job samples ``samples_per_n`` designs for each number of units ``N``. The plan of one ``N`` is a
point set in the unit cube ``[0, 1)^d`` with one dimension per sampled quantity
(:func:`plan_dimensions`): ``H_1..H_N``, then ``U_L`` and ``U_sep`` (one dimension each when the
job makes them equal across units, else one per unit), then the sampled shared variables
(``t``, ``t_lim``, and ``E``, ``nu``, ``r_b``, ``t_ch`` when given as ranges). Fixed variables take
no dimension. Points are scaled to ``[min, max]`` with :func:`scipy.stats.qmc.scale`.

Reproducible and chunk-invariant
    Design ``i`` of the plan for ``N`` depends only on ``(seed, N, samples_per_n, i)`` and the
    space, never on how the sweep is cut into chunks or which worker evaluates it: any slice
    ``[start, stop)`` is produced on its own (:func:`sample_designs`) and equals the same rows of
    the whole plan, bit for bit.

Latin hypercube (``sampler = "lhs"``)
    :class:`scipy.stats.qmc.LatinHypercube` (``scramble=True``: random permutations of the
    strata in every dimension, uniform jitter inside each stratum). SciPy draws a plan of ``n``
    points at once, and nothing of it can be drawn piecewise, so a plan larger than
    :data:`LHS_BLOCK` points is the union of independent Latin hypercubes of ``LHS_BLOCK`` points
    (the last one shorter), each seeded by ``(seed, N, block index)``: a *replicated* Latin
    hypercube. Memory is then bounded by one block (``LHS_BLOCK * d * 8`` bytes, 21 MB at 40
    dimensions, plus SciPy's temporaries), not by the sweep size, and a chunk draws only the
    blocks it overlaps (the last block drawn is cached per process, so consecutive chunks of one
    block draw it once). Every plan of up to ``LHS_BLOCK`` points (the paper's 1500 per N) is one
    exact Latin hypercube; a larger plan is exactly stratified within each block, so every
    marginal has exactly one point per ``1/LHS_BLOCK`` stratum per full block - a resolution at
    which stratifying finer changes nothing measurable. The alternative, one Latin hypercube of
    10^6 points, needs the whole ``n x d`` plan (160 MB at 20 dimensions, several times that in
    SciPy's temporaries) in every process that evaluates a chunk.

Scrambled Sobol' (``sampler = "sobol"``)
    :class:`scipy.stats.qmc.Sobol` seeded by ``(seed, N)``; a chunk ``[start, stop)`` is
    ``fast_forward(start)`` then ``random(stop - start)``, so the plan is one sequence however
    it is chunked. Its balance properties need ``samples_per_n`` to be a power of 2.

Constraints without destroying stratification
    * ``equal_U_sep`` / ``equal_U_L``: the shared value is one dimension of the plan, broadcast
      to the units, so it is stratified like any other dimension (and the plan has fewer
      dimensions, which is what the constraint means).
    * ``heights = "ascending"`` (``H_1 <= ... <= H_N``) or ``"descending"``: rejection would
      keep ``1/N!`` of the points and break the strata; sorting each point's heights gives the
      right distribution (uniform on the ordered region) but leaves no coordinate stratified.
      We map the ``N`` stratified height coordinates ``u_1..u_N`` through the *Rosenblatt
      transform* of the uniform distribution on the ordered region: ``y_1`` is the inverse CDF
      of the minimum of ``N`` uniforms at ``u_1``, ``y_1 = 1 - (1 - u_1)^(1/N)``; given it, the
      other heights are uniform and ordered on ``[y_1, 1)``, so ``y_k = y_(k-1) + (1 -
      y_(k-1)) (1 - (1 - u_k)^(1/(N-k+1)))``. The map is a bijection from the cube onto the
      ordered region that carries the uniform density to the uniform density, so each point is
      uniform on the constrained region (each ``H_k`` follows the order-statistic law
      ``Beta(k, N+1-k)`` on its range, as it must), every ``u_k`` keeps its Latin-hypercube
      strata, and the height of unit 1 is stratified in the quantiles of its own marginal law
      (exactly one point per ``1/n`` quantile stratum; ``tests/sweep/test_sampling.py`` checks
      this). For ``"descending"`` the heights are mirrored, ``1 - y``, so unit 1 (the base) is
      the tallest.
"""

from __future__ import annotations

import functools
import threading
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import qmc

from ..model.design import DesignBatch
from ..model.domain import MAX_UNITS
from .space import PER_UNIT_VARIABLES, SHARED_VARIABLES, DesignSpace, JobSpec

__all__ = [
    "LHS_BLOCK",
    "Dimension",
    "order_heights",
    "plan_dimensions",
    "sample_designs",
    "unit_cube_sample",
]

#: Points per independent Latin hypercube of a large plan (see the module docstring). Part of
#: the plan's definition: changing it changes every plan larger than it.
LHS_BLOCK = 1 << 16


@dataclass(frozen=True)
class Dimension:
    """One dimension of a plan: a variable, and the unit it belongs to.

    Attributes
    ----------
    variable : str
        Design variable (``"H"``, ``"U_L"``, ``"t"``, ...).
    unit : int or None
        Unit number (1 = base) of a per-unit variable; None for a shared variable or a per-unit
        variable the job makes equal across units.
    """

    variable: str
    unit: int | None = None

    @property
    def label(self) -> str:
        """``"H_3"`` for a per-unit dimension, the variable name otherwise."""
        return self.variable if self.unit is None else f"{self.variable}_{self.unit}"


def plan_dimensions(space: DesignSpace, n_units: int) -> tuple[Dimension, ...]:
    """Dimensions of the plan for designs of ``n_units`` units, in plan order."""
    dims: list[Dimension] = []
    for name in PER_UNIT_VARIABLES:
        if not space.variable(name).sampled:
            continue
        if space.shared_across_units(name):
            dims.append(Dimension(name))
        else:
            dims.extend(Dimension(name, k) for k in range(1, n_units + 1))
    dims.extend(Dimension(name) for name in SHARED_VARIABLES if space.variable(name).sampled)
    return tuple(dims)


def unit_cube_sample(
    sampler: str, seed: int, n_units: int, n_samples: int, d: int, start: int, stop: int
) -> NDArray[np.float64]:
    """Rows ``[start, stop)`` of the unit-cube plan (before constraints and scaling).

    Parameters
    ----------
    sampler : {"lhs", "sobol"}
    seed : int
        Job seed (>= 0).
    n_units : int
        Number of units; with ``seed`` it selects the random streams of this plan.
    n_samples : int
        Size of the whole plan for this ``n_units`` (it sets the Latin-hypercube strata).
    d : int
        Number of dimensions.
    start, stop : int
        Row range, ``0 <= start <= stop <= n_samples``.

    Returns
    -------
    ndarray of shape (stop - start, d)
        Points in ``[0, 1)^d``.
    """
    if not 0 <= start <= stop <= n_samples:
        raise ValueError(f"rows [{start}, {stop}): outside the plan of {n_samples} points")
    if d == 0 or stop == start:
        return np.empty((stop - start, d))
    if sampler == "sobol":
        return _sobol_rows(seed, n_units, d, start, stop)
    if sampler != "lhs":
        raise ValueError(f"sampler = {sampler!r}: must be 'lhs' or 'sobol'")
    out = np.empty((stop - start, d))
    first, last = start // LHS_BLOCK, (stop - 1) // LHS_BLOCK
    for block in range(first, last + 1):
        block_start = block * LHS_BLOCK
        block_len = min(LHS_BLOCK, n_samples - block_start)
        points = _lhs_block(seed, n_units, d, block, block_len)
        lo, hi = max(start, block_start), min(stop, block_start + block_len)
        out[lo - start : hi - start] = points[lo - block_start : hi - block_start]
    return out


# One block is 2**16 x d doubles; two cached blocks cover a chunk that straddles a boundary.
@functools.lru_cache(maxsize=2)
def _lhs_block(seed: int, n_units: int, d: int, block: int, block_len: int) -> NDArray:
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(n_units, block)))
    points = qmc.LatinHypercube(d, scramble=True, rng=rng).random(block_len)
    points.flags.writeable = False
    return points


_SOBOL_LOCK = threading.Lock()


def _sobol_rows(seed: int, n_units: int, d: int, start: int, stop: int) -> NDArray:
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(n_units,)))
    with _SOBOL_LOCK, warnings.catch_warnings():
        # Balance needs power-of-2 *plans*; a chunk of any size is a slice of one plan.
        warnings.filterwarnings("ignore", message="The balance properties", category=UserWarning)
        engine = qmc.Sobol(d, scramble=True, rng=rng)
        if start:
            engine.fast_forward(start)
        return engine.random(stop - start)


def order_heights(u: NDArray, order: str) -> NDArray:
    """Map stratified unit-cube heights onto the ordered region (Rosenblatt transform).

    Parameters
    ----------
    u : ndarray of shape (m, N)
        Height coordinates in ``[0, 1)``, unit 1 first.
    order : {"free", "ascending", "descending"}

    Returns
    -------
    ndarray of shape (m, N)
        In ``[0, 1]``: unchanged for ``"free"``; else non-decreasing (``"ascending"``) or
        non-increasing (``"descending"``) along each row, uniform on that ordered region (see
        the module docstring).
    """
    if order == "free":
        return u
    if order not in ("ascending", "descending"):
        raise ValueError(f"heights = {order!r}: must be 'free', 'ascending' or 'descending'")
    m, n = u.shape
    y = np.empty_like(u)
    previous = np.zeros(m)
    for k in range(n):
        remaining = n - k
        # 1 - (1 - u)^(1/r) without cancellation for small u: the inverse CDF of the minimum
        # of r uniforms.
        fraction = -np.expm1(np.log1p(-u[:, k]) / remaining)
        previous = previous + (1.0 - previous) * fraction
        y[:, k] = previous
    return 1.0 - y if order == "descending" else y


def sample_designs(spec: JobSpec, n_units: int, start: int, stop: int) -> DesignBatch:
    """Designs ``[start, stop)`` of the job's plan for ``n_units`` units.

    Parameters
    ----------
    spec : JobSpec
    n_units : int
        One of ``spec.space.n_units``.
    start, stop : int
        Row range of the plan, ``0 <= start <= stop <= spec.samples_per_n``.

    Returns
    -------
    DesignBatch
        ``stop - start`` designs, per-unit arrays NaN-padded beyond ``n_units``. Row ``j`` is
        design ``start + j`` of the plan whatever the range asked for.
    """
    space = spec.space
    if n_units not in space.n_units:
        raise ValueError(f"n_units = {n_units}: not in the job's space.n_units {space.n_units}")
    dims = plan_dimensions(space, n_units)
    cube = unit_cube_sample(
        spec.sampler, spec.seed, n_units, spec.samples_per_n, len(dims), start, stop
    )
    labels = [dim.label for dim in dims]
    height_columns = [j for j, dim in enumerate(dims) if dim.variable == "H"]
    if height_columns and space.heights != "free":
        cube = cube.copy()
        cube[:, height_columns] = order_heights(cube[:, height_columns], space.heights)
    if dims:
        lows = [space.variable(dim.variable).low for dim in dims]
        highs = [space.variable(dim.variable).high for dim in dims]
        scaled = qmc.scale(np.clip(cube, 0.0, 1.0), lows, highs)
    else:
        scaled = cube
    column = {label: scaled[:, j] for j, label in enumerate(labels)}
    m = stop - start
    per_unit = {}
    for name in PER_UNIT_VARIABLES:
        values = np.full((m, MAX_UNITS), np.nan)
        variable = space.variable(name)
        for k in range(1, n_units + 1):
            if not variable.sampled:
                values[:, k - 1] = variable.low
            elif space.shared_across_units(name):
                values[:, k - 1] = column[name]
            else:
                values[:, k - 1] = column[f"{name}_{k}"]
        per_unit[name] = values
    shared = {
        name: column[name] if space.variable(name).sampled else np.full(m, space.variable(name).low)
        for name in SHARED_VARIABLES
    }
    return DesignBatch(
        n_units=np.full(m, n_units, dtype=np.int64),
        **per_unit,
        **shared,
        constants=spec.constants,
    )
