"""What a lookup reports: candidates re-solved by the exact model, and where each value comes from.

:class:`Candidate` is one reported design with its verified outputs and their provenance;
:class:`LookupResult` is the answer of :func:`~.query.lookup` (best candidate first, the
filters, the index, notes), with the JSON form the CLI prints.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from numpy.typing import NDArray

from ..model.design import Design
from ..model.formatting import json_number
from ..model.quantities import STATE_OUTPUT_NAMES
from ..sweep.storage.datasets import DatasetInfo
from .index import LookupIndex
from .polish import Refinement
from .store import IndexOrigin

__all__ = [
    "REREAD",
    "REREAD_UNVERIFIED",
    "RESOLVED",
    "RESOLVED_COLUMNS",
    "STATUS_ORDER",
    "VERIFIED_NOTE",
    "Candidate",
    "LookupResult",
    "provenance_note",
]

#: Order of candidate statuses in the output (best first within a status by error).
STATUS_ORDER = ("ok", "not_met", "collapsed", "failed")
VERIFIED_NOTE = "every reported design was re-solved by the exact model before it was reported"
#: Columns the verification solve recomputes (every per-state output of the model,
#: :data:`~dpfexplore.model.quantities.STATE_OUTPUTS`); any other reported column is re-read.
RESOLVED_COLUMNS = STATE_OUTPUT_NAMES
#: Provenance of a reported value (:attr:`Candidate.provenance`).
RESOLVED, REREAD, REREAD_UNVERIFIED = "re-solved", "re-read", "re-read-unverified"
#: Columns the table always prints besides the indexed ones (all re-solved).
_ALWAYS_PRINTED = ("tip_x", "tip_y", "stiffness")


@dataclass(frozen=True)
class Candidate:
    """One reported design, re-solved by the exact model.

    Attributes
    ----------
    design : Design
    state : str
        The state whose outputs match the target (unit 1 first).
    found : str
        The state the verification solve settled in ("" if none): equal to ``state`` unless the
        status is ``"collapsed"``.
    status : {"ok", "not_met", "collapsed", "failed"}
        ``ok``: the state exists (and, when refined, the target is met to the tolerance);
        ``not_met``: refined, the state exists, the target is not met; ``collapsed``: the state
        does not exist at the design, or collapsed on the way to the target; ``failed``: the
        solver failed.
    values : ndarray of shape (d,)
        The indexed columns at the design: re-solved where the model computes them, else
        re-read from the design's dataset row (see ``provenance``).
    tip : ndarray of shape (2,), mm
    stiffness : float, N/mm
    error : float
        Scaled distance from the target (mm for the tip).
    error_mm : float or None
        Tip distance from the target's tip (mm), when the target includes the tip.
    met : bool
        ``error <= tol``.
    refined : bool
    design_id : int
        The dataset row the candidate started from.
    source_distance : float
        That row's scaled distance from the target.
    source_values : ndarray of shape (d,)
        That row's values in the dataset (re-read from its chunk, not the index's copy).
    fitted_range : bool
    fitted_range_note : str or None
    refinement : Refinement or None
    provenance : tuple of str
        Per indexed column, where ``values`` comes from: ``"re-solved"`` (the verification
        solve), ``"re-read"`` (the dataset row, read through a SHA-256 check),
        ``"re-read-unverified"`` (the same without the check, ``verify=False``) or ``"none"``
        (a refined design, for a column the model does not compute: NaN).
    also_from : tuple of int
        design_ids of other candidates that were the same design in the same state, merged
        into this one.
    """

    design: Design
    state: str
    found: str
    status: str
    values: NDArray
    tip: NDArray
    stiffness: float
    error: float
    error_mm: float | None
    met: bool
    refined: bool
    design_id: int
    source_distance: float
    source_values: NDArray
    fitted_range: bool
    fitted_range_note: str | None
    refinement: Refinement | None = None
    provenance: tuple[str, ...] = ()
    also_from: tuple[int, ...] = ()

    def to_dict(self, columns: Sequence[str]) -> dict[str, Any]:
        """JSON-ready mapping (``"design"`` holds the keys of a ``[design]`` table)."""
        design = self.design.to_dict()
        design.pop("name", None)
        out = {
            "design": design,
            "n_units": self.design.n_units,
            "state": self.state,
            "found": self.found,
            "tip": [json_number(v) for v in self.tip],
            "error_mm": json_number(self.error_mm),
            "error": json_number(self.error),
            "stiffness": json_number(self.stiffness),
            "status": self.status,
            "met": self.met,
            "values": {c: json_number(v) for c, v in zip(columns, self.values, strict=True)},
            "provenance": {
                "tip": RESOLVED,
                "stiffness": RESOLVED,
                **(dict(zip(columns, self.provenance, strict=True)) if self.provenance else {}),
            },
            "refined": self.refined,
            "fitted_range": self.fitted_range,
            "fitted_range_note": self.fitted_range_note,
            "verified": True,
            "source": {
                "design_id": self.design_id,
                "distance": json_number(self.source_distance),
                "values": {
                    c: json_number(v) for c, v in zip(columns, self.source_values, strict=True)
                },
                "also_from": list(self.also_from),
            },
        }
        if self.refinement is not None:
            r = self.refinement
            out["refinement"] = {
                "status": r.status,
                "evaluations": r.evaluations,
                "jacobians": r.jacobians,
                "collapses": r.collapses,
                "seconds": r.seconds,
                "message": r.message,
            }
        return out


@dataclass(frozen=True)
class LookupResult:
    """What :func:`lookup` found.

    Attributes
    ----------
    target : ndarray of shape (d,)
    columns : tuple of str
    scales : ndarray of shape (d,)
    tol : float
    candidates : list of Candidate
        Best first: by status (:data:`STATUS_ORDER`), then by error.
    refined : bool
    reachable : bool
        Whether a reported candidate meets the target to ``tol`` (with refinement, after it;
        without, a dataset design as it is: refine to get closer).
    dataset : DatasetInfo
    index_origin : IndexOrigin or None
        None when the caller passed an index.
    index_rows : int
        Rows in the index.
    query_seconds : float
        The nearest-neighbour query alone.
    seconds : float
        The whole lookup (index, query, designs, refinement, verification).
    notes : list of str
        Things the user must know (incomplete dataset, rebuilt index, verification).
    state, n_units, where
        The filters of the lookup.
    index : LookupIndex
        The index that answered (for :func:`reachable_tips`).
    verified : bool
        The dataset rows were read through a SHA-256 check (``verify=True``).
    """

    target: NDArray
    columns: tuple[str, ...]
    scales: NDArray
    tol: float
    candidates: list[Candidate]
    refined: bool
    reachable: bool
    dataset: DatasetInfo
    index_origin: IndexOrigin | None
    index_rows: int
    query_seconds: float
    seconds: float
    notes: list[str] = field(default_factory=list)
    state: str | int | None = None
    n_units: tuple[int, ...] | None = None
    where: str | None = None
    index: LookupIndex | None = field(default=None, repr=False, compare=False)
    verified: bool = True

    @property
    def provenance(self) -> dict[str, str]:
        """Where each printed column's values come from, over all candidates.

        The tip and stiffness (always printed) and every indexed column, each ``"re-solved"``,
        ``"re-read"``, ``"re-read-unverified"`` or ``"none"``; several kinds joined by ``+``.
        """
        out = {c: RESOLVED for c in _ALWAYS_PRINTED}
        for j, column in enumerate(self.columns):
            kinds = sorted({c.provenance[j] for c in self.candidates if c.provenance})
            out[column] = "+".join(kinds) if kinds else RESOLVED
        return out

    @property
    def best(self) -> Candidate:
        """The first candidate (the nearest design found when the target is unreachable)."""
        return self.candidates[0]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready mapping: ``{"target": [...], "candidates": [...], ...}``."""
        origin = self.index_origin
        return {
            "target": [float(v) for v in self.target],
            "columns": list(self.columns),
            "scales": [float(v) for v in self.scales],
            "tol": self.tol,
            "refined": self.refined,
            "reachable": self.reachable,
            "filters": {
                "state": self.state,
                "n_units": list(self.n_units) if self.n_units is not None else None,
                "where": self.where,
            },
            "candidates": [c.to_dict(self.columns) for c in self.candidates],
            "provenance": self.provenance,
            "dataset": {
                "path": str(self.dataset.root),
                "complete": self.dataset.complete,
                "designs_committed": self.dataset.designs_committed,
                "designs_planned": self.dataset.designs_planned,
            },
            "index": {
                "rows": self.index_rows,
                "action": origin.action if origin else "given",
                "path": str(origin.path) if origin else None,
                "seconds": origin.seconds if origin else None,
                "saved": origin.saved if origin else None,
                "verified": origin.verified if origin else None,
                "reason": origin.reason if origin else None,
            },
            "rows_verified": self.verified,
            "query_seconds": self.query_seconds,
            "seconds": self.seconds,
            "notes": list(self.notes),
        }


def provenance_note(provenance: Mapping[str, str]) -> str:
    """:data:`VERIFIED_NOTE` when every printed column is re-solved, else which are re-read."""
    reread = [c for c, kind in provenance.items() if kind != RESOLVED]
    if not reread:
        return VERIFIED_NOTE
    resolved = [c for c, kind in provenance.items() if kind == RESOLVED]
    unverified = [c for c in reread if REREAD_UNVERIFIED in provenance[c]]
    missing = [c for c in reread if "none" in provenance[c]]
    it = "it" if len(reread) == 1 else "them"
    text = (
        f"the designs were re-solved by the exact model for {', '.join(resolved)}; "
        f"{', '.join(reread)} {'was' if len(reread) == 1 else 'were'} re-read from each "
        f"design's dataset row (the model does not compute {it})"
    )
    if unverified:
        text += ", without a SHA-256 check of its chunk (--no-verify)"
    else:
        text += ", checked against the manifest's SHA-256"
    if missing:
        text += f"; no value for refined designs: {', '.join(missing)}"
    return text
