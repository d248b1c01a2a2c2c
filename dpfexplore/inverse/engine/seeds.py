"""Optimiser candidates from a sweep dataset: the lookup index instead of a Latin hypercube.

A position scene may name a sweep dataset (``[optimiser] seeds = "DIR"``, or ``dpfexplore design
--seeds DIR``). Its candidates are then, for every N, the dataset's designs whose tip lies
nearest the target (:mod:`dpfexplore.lookup.index`) and that satisfy the scene's
variables (:meth:`DesignVariables.encode`): no model evaluation is spent on screening, since
the dataset's tips are the exact model's own (same model version, checked). Refinement then
starts from the nearest seeds as it would from the best Latin-hypercube points.

Shapes do not depend on ``E`` (every spring constant is proportional to it, MODEL.md §5), so a
dataset of one material seeds scenes of another: the seeds take the scene's ``E``. The Poisson
ratio does change shapes (through ``k_t``), so it must match, as must every other fixed
parameter. A dataset sampled with the scene's constraints (e.g. ``jobs/design-seeds-*.toml``:
ordered heights, shared ``U_L`` and ``U_sep``) gives only usable seeds; any sweep works, with
fewer of its rows usable.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ...lookup.index import LookupIndex
from ...lookup.query import designs_of
from ...lookup.store import open_index
from ...model.design import DesignBatch
from ...model.variables import DesignVariables
from ...model.version import MODEL_VERSION
from ...sweep.storage.datasets import dataset_info
from ..evaluation import SceneEvaluator
from .problem import Evaluation

__all__ = ["SeedSet", "SeedableProblem", "open_seeds", "seed_candidates"]

#: Tip columns the seeds are looked up by.
_COLUMNS = ("tip_x", "tip_y")
#: Seed datasets kept open in this process (the most recent ones).
_KEEP_OPEN = 2


@dataclass
class SeedSet:
    """A seed dataset opened for a process: its tip index and, per N, its designs.

    A scene's targets, and every scene of a run that names the same dataset, share one: the
    design columns of an N are read from the chunk files once (~20 ms per 20,000 designs),
    not once per target.
    """

    index: LookupIndex
    _designs: dict[int, tuple[NDArray[np.int64], DesignBatch]] = field(default_factory=dict)

    def designs(self, rows: NDArray[np.int64], n_units: int) -> DesignBatch:
        """The designs of index ``rows`` (all of ``n_units`` units)."""
        if n_units not in self._designs:
            all_rows = np.flatnonzero(self.index.n_units == n_units)
            self._designs[n_units] = (all_rows, designs_of(self.index, all_rows))
        all_rows, batch = self._designs[n_units]
        return batch.take(np.searchsorted(all_rows, rows))


_OPEN: dict[tuple[str, str], SeedSet] = {}


class SeedableProblem(Protocol):
    """What seeding needs of a problem: a tip target of one state, in a box of variables."""

    variables: DesignVariables
    #: Tip ``(x, y)`` the problem drives its state to, mm.
    target: NDArray
    #: The targeted state (an integer, unit 1 the most significant bit).
    state: int
    dim: int

    @property
    def n_units(self) -> int: ...  # noqa: D102


def open_seeds(dataset: str | Path, n_units: tuple[int, ...] = ()) -> SeedSet:
    """The :class:`SeedSet` of a dataset, opened once per process and content checksum.

    ``n_units``: read these N's designs now (else on first use). A dataset that changed since
    it was opened (another checksum) is opened again; one written by another model version is
    refused.
    """
    info = dataset_info(dataset)
    if info.model_version != MODEL_VERSION:
        raise ValueError(
            f"seeds = {str(dataset)!r}: written by model version {info.model_version!r}, "
            f"this dpfexplore computes {MODEL_VERSION!r}; rerun its sweep"
        )
    key = (str(Path(dataset).resolve()), info.checksum)
    if key not in _OPEN:
        while len(_OPEN) >= _KEEP_OPEN:
            _OPEN.pop(next(iter(_OPEN)))
        _OPEN[key] = SeedSet(open_index(dataset, _COLUMNS, info=info)[0])
    seeds = _OPEN[key]
    for n in n_units:
        if n in seeds.index.n_values:
            seeds.designs(np.empty(0, dtype=np.int64), n)
    return seeds


def seed_candidates(
    problems: list[SeedableProblem], dataset: str | Path, per_n: int, evaluator: SceneEvaluator
) -> list[Evaluation | None]:
    """Per problem (one per N), up to ``per_n`` dataset designs nearest its target.

    Returns, for each problem, an :class:`Evaluation` of the usable seeds (their ``z``, the
    dataset's tips as residuals; ``columns["design_id"]`` names the rows), or None when the
    dataset has none for that N (the caller screens a Latin hypercube instead). The seeds are
    counted as ``seeds``; no model evaluation is spent.
    """
    seeds = open_seeds(dataset)
    index = seeds.index
    out: list[Evaluation | None] = []
    for problem in problems:
        n = problem.n_units
        if n not in index.n_values:
            out.append(None)
            continue
        # More rows than needed: some may break the scene's constraints.
        _, rows = index.query(problem.target, 4 * per_n, n_units=[n], state=problem.state)
        if rows.size == 0:
            out.append(None)
            continue
        batch = seeds.designs(rows, n)
        batch = replace(batch, E=np.full(len(batch), problem.variables.E))
        z, inside = problem.variables.encode(batch)
        keep = np.flatnonzero(inside)[:per_n]
        if keep.size == 0:
            out.append(None)
            continue
        tips = index.points[rows[keep]]
        evaluator.count("seeds", int(keep.size))
        out.append(
            Evaluation(
                z=z[keep],
                ok=np.ones(keep.size, dtype=bool),
                residual=tips - problem.target,
                stiffness=np.full(keep.size, np.nan),
                columns={"design_id": index.design_id[rows[keep]]},
            )
        )
    return out
