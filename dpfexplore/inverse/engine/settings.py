"""The optimiser's budget: what a scene's ``[optimiser]`` table sets."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["OptimiserSettings"]


@dataclass(frozen=True)
class OptimiserSettings:
    """Budget of the optimiser (see :mod:`dpfexplore.inverse.engine.optimiser`).

    Attributes
    ----------
    candidates_per_n : int
        Latin-hypercube candidates per number of units.
    starts_per_n : int
        Gradient refinements per number of units before a target is declared unreachable.
    max_iter : int
        Residual evaluations per refinement.
    seeds : str or None
        Sweep dataset whose nearest designs are the candidates (None: a Latin hypercube).
    seeds_per_n : int
        Seeds per number of units.
    """

    candidates_per_n: int = 64
    starts_per_n: int = 3
    max_iter: int = 60
    seeds: str | None = None
    seeds_per_n: int = 8
