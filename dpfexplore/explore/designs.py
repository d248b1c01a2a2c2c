"""A click on the map, answered: the dataset's designs nearest to a tip, refined and verified.

:class:`DesignFinder` runs the lookup's stages (:mod:`dpfexplore.lookup`) on the rows the page
shows: the nearest-neighbour index over the tip (loaded beside the dataset, or built and saved
there once, as ``dpfexplore lookup`` does), restricted to the rows passing the page's filters by
a row mask, the candidates read back from their verified chunks, polished with the exact model
until the tip meets the target (:func:`~dpfexplore.lookup.polish.refine`) and re-solved
(:func:`~dpfexplore.lookup.rows.verified_candidates`). Each answer (:class:`Pick`) carries the
finger drawn in its states (the matched one and the sequential ones), found by the exact
model, and its design as the TOML text of a ``[design]`` file that ``dpfexplore states`` and
``simulate`` read, parsed back into a design equal to the candidate's before it is offered.
"""

from __future__ import annotations

import time
import tomllib
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..lookup.files import design_toml
from ..lookup.index import LookupIndex, mask_of
from ..lookup.polish import refine, variables_for
from ..lookup.results import STATUS_ORDER, Candidate
from ..lookup.rows import merge_duplicates, read_rows, sort_error, verified_candidates
from ..lookup.store import open_index
from ..model.design import Design
from ..solvers.statics import StateResult, find_state, sequential_states
from ..sweep.job_file import recorded_space
from .data import ExploreData

__all__ = ["DesignFinder", "Pick", "design_file_text"]

#: Tip tolerance of the refinement, mm (the lookup's default).
TOLERANCE_MM = 1e-6
#: Model evaluations per refinement.
MAX_EVALUATIONS = 60
#: Dataset columns shown with a pick besides the re-solved outputs (re-read from its row).
_REREAD_PREFIXES = ("reset_time",)


@dataclass(frozen=True)
class Pick:
    """One verified design for a target.

    Attributes
    ----------
    candidate : Candidate
        The lookup's candidate (re-solved outputs, tip error, status, provenance).
    states : list of StateResult
        The finger in its matched state first, then its sequential states (exact model).
    toml : str
        A ``[design]`` file of the design, read back.
    dataset_values : dict of str to float
        Columns the model does not re-solve, from the design's dataset row (reset times), when
        the design was not moved by the refinement; empty otherwise.
    """

    candidate: Candidate
    states: list[StateResult]
    toml: str
    dataset_values: dict[str, float]


def design_file_text(candidate: Candidate, dataset: str) -> str:
    """The ``[design]`` TOML text of a candidate, parsed back to the same design.

    Raises
    ------
    ValueError
        If the text does not read back to the candidate's design.
    """
    design = candidate.design
    comments = [
        f"design from dpfexplore explore over {dataset} (row design_id {candidate.design_id})",
        f"state {candidate.state}: tip ({candidate.tip[0]:.6g}, {candidate.tip[1]:.6g}) mm, "
        f"stiffness {candidate.stiffness:.6g} N/mm, status {candidate.status}, "
        "re-solved by the exact model",
    ]
    result = {
        "state": candidate.state,
        "tip": [float(v) for v in candidate.tip],
        "stiffness": float(candidate.stiffness),
        "error_mm": candidate.error_mm,
        "status": candidate.status,
    }
    text = design_toml(design, comments, result)
    back = Design.from_dict(tomllib.loads(text)["design"] | {"name": design.name})
    if back.to_dict() != design.to_dict():
        raise ValueError(f"design of row {candidate.design_id}: its TOML does not read back")
    return text


class DesignFinder:
    """The lookup of one dataset, kept open for the page's clicks.

    Parameters
    ----------
    data : ExploreData
    k : int
        Candidates per click.
    """

    def __init__(self, data: ExploreData, *, k: int = 3) -> None:
        self.data = data
        self.k = int(k)
        self.index: LookupIndex
        self.index, self.origin = open_index(data.root, info=data.info)
        self._space = recorded_space(data.info.job)
        self._masks: dict[bytes, NDArray[np.bool_]] = {}
        self._reread = [c for c in data.columns if c.startswith(_REREAD_PREFIXES)]

    def index_mask(self, keep: NDArray[np.bool_]) -> NDArray[np.bool_] | None:
        """The index rows among the data rows ``keep`` (None when every row is kept)."""
        if keep.all():
            return None
        key = np.packbits(keep).tobytes()
        mask = self._masks.get(key)
        if mask is None:
            mask = mask_of(
                self.index,
                {"design_id": self.data.design_id[keep], "requested": self.data.requested[keep]},
            )
            self._masks = {key: mask}  # the page's current filters only
        return mask

    def find(self, target: ArrayLike, keep: NDArray[np.bool_]) -> tuple[list[Pick], float]:
        """The verified designs nearest to ``target`` among the rows ``keep``, and the seconds.

        Raises
        ------
        ValueError
            No ``ok`` row passes the filters, or the target is not two finite numbers.
        """
        start = time.perf_counter()
        target = np.asarray(target, dtype=float).reshape(-1)
        if target.shape != (2,) or not np.all(np.isfinite(target)):
            raise ValueError(f"target {target.tolist()!r}: need two finite numbers (x, y) in mm")
        mask = self.index_mask(keep)
        _, rows = self.index.query(target, self.k, mask=mask)
        if rows.size == 0:
            raise ValueError("no row with status ok passes the filters: widen them")
        batch, source_values = read_rows(
            self.index, rows, info=self.data.info, constants=self.data.constants
        )
        states = self.index.requested[rows]
        refinements = []
        for i in range(rows.size):
            design = batch.design(i)
            refinements.append(
                refine(
                    design,
                    int(states[i]),
                    target,
                    variables=variables_for(self._space, design, None),
                    columns=self.index.columns,
                    scales=self.index.scales,
                    tol=TOLERANCE_MM,
                    max_evaluations=MAX_EVALUATIONS,
                )
            )
        designs = [r.design for r in refinements]
        candidates = verified_candidates(
            designs,
            states,
            rows,
            source_values,
            self.index,
            target,
            TOLERANCE_MM,
            refinements,
            True,
        )
        candidates.sort(key=lambda c: (STATUS_ORDER.index(c.status), sort_error(c.error)))
        candidates, _ = merge_duplicates(candidates)
        originals = {}
        for i, r in enumerate(rows):
            design = batch.design(i)
            key = (int(self.index.design_id[r]), format(int(states[i]), f"0{design.n_units}b"))
            originals[key] = design
        picks = [self._pick(c, originals[c.design_id, c.state]) for c in candidates]
        return picks, time.perf_counter() - start

    def _pick(self, candidate: Candidate, original: Design) -> Pick:
        design = candidate.design
        matched = find_state(design, candidate.state)
        others = [
            find_state(design, s)
            for s in sequential_states(design)
            if format(s, f"0{design.n_units}b") != candidate.state
        ]
        values = {}
        moved = design.to_dict() != original.to_dict()
        if self._reread and not moved:
            row = np.flatnonzero(
                (self.data.design_id == candidate.design_id) & (self.data.state == candidate.state)
            )
            if row.size:
                values = {c: float(self.data.columns[c][row[0]]) for c in self._reread}
        return Pick(
            candidate=candidate,
            states=[matched, *others],
            toml=design_file_text(candidate, str(self.data.root)),
            dataset_values=values,
        )
