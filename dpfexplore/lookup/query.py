"""Lookup: from target outputs to verified designs, through a sweep dataset.

:func:`lookup` answers *which finger does this?* for a sweep dataset: the ``k`` rows whose
outputs (the tip by default) are nearest to the target (:mod:`.lookup_index`), optionally
polished with the exact model until the target is met (:func:`~.refine.refine`), each reported
design re-solved by the exact model before it is returned::

    >>> from dpfexplore.lookup.query import lookup
    >>> result = lookup("results/paper-design-space", [25.0, 40.0], state="all-inverted",
    ...                 k=5, refine=True, constraints={"heights": "descending"})
    >>> best = result.candidates[0]
    >>> best.status, best.error, best.design            # doctest: +SKIP

Guarantees
    * The rows come from the committed chunks only; a dataset still being written is read as
      far as it is committed and :attr:`LookupResult.notes` says so.
    * Every reported design is re-solved (all candidates in one
      :func:`~dpfexplore.solvers.statics.solve_batch` call); its tip, stiffness, state and
      error are those of that solve, never the dataset's or the refinement's values.
    * Every reported value says where it comes from (:attr:`Candidate.provenance`):
      ``"re-solved"`` for the columns the model computes (:data:`RESOLVED_COLUMNS`: the tip,
      stiffness, energies, angles, ...), ``"re-read"`` for the others (reset times, ...), read
      back from the candidate's row of the verified chunk, never from the index's copy
      (``"re-read-unverified"`` with ``verify=False``). The index only chooses the rows: each
      row read back must have the design_id and state the index gave it, else the index is
      rebuilt and the query made again.
    * A design is reported once: candidates of the same state whose designs are the same (the
      same dataset row, or refinements that ended on the same design, e.g. at a corner of the
      box) are merged into the best of them (:attr:`Candidate.also_from`).
    * A design outside the range the closed forms were fitted on (MODEL.md §3) carries
      ``fitted_range = False`` and a note.
    * With ``refine=True``, the target is *reachable* when some candidate meets it; otherwise the
      best candidate is the nearest design found and :func:`reachable_tips` gives the region the
      dataset covers, per ``N``, for a plot (:func:`dpfexplore.plotting.lookup.plot_reachable`).
"""

from __future__ import annotations

import logging
import math
import re
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
from numpy.typing import ArrayLike, NDArray

from ..model import status as st
from ..model.constants_set import ConstantsSet
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS
from ..model.formatting import json_number
from ..model.version import MODEL_VERSION
from ..solvers.statics import OUTPUT_COLUMNS, solve_batch, state_string
from ..sweep.datasets import DatasetInfo, dataset_info
from ..sweep.row_filter import parse_filter
from ..sweep.space import parse_job
from ..sweep.store import read_results, read_schema
from .index import DEFAULT_COLUMNS, LookupIndex, StaleIndexError, mask_of
from .polish import REFINABLE_COLUMNS, Refinement, variables_for
from .polish import refine as refine_design
from .store import IndexOrigin, open_index

__all__ = [
    "RESOLVED_COLUMNS",
    "Candidate",
    "LookupResult",
    "lookup",
    "parse_n_units",
    "reachable_tips",
]

logger = logging.getLogger(__name__)

#: Order of candidate statuses in the output (best first within a status by error).
STATUS_ORDER = ("ok", "not_met", "collapsed", "failed")
VERIFIED_NOTE = "every reported design was re-solved by the exact model before it was reported"
#: Columns the verification solve recomputes; any other reported column is re-read.
RESOLVED_COLUMNS = tuple(OUTPUT_COLUMNS)
#: Provenance of a reported value (:attr:`Candidate.provenance`).
RESOLVED, REREAD, REREAD_UNVERIFIED = "re-solved", "re-read", "re-read-unverified"
#: Columns the table always prints besides the indexed ones (all re-solved).
_ALWAYS_PRINTED = ("tip_x", "tip_y", "stiffness")
#: Two designs whose parameters (mm, 1, MPa) differ by no more than this are the same design.
_SAME_DESIGN_ATOL = 1e-9


def parse_n_units(text: str) -> tuple[int, ...]:
    """``"5"``, ``"3..8"`` or ``"3,5,7"`` as a tuple of numbers of units."""
    text = text.strip()
    match = re.fullmatch(r"(\d+)\s*\.\.\s*(\d+)", text)
    try:
        if match:
            low, high = int(match[1]), int(match[2])
            if low > high:
                raise ValueError
            values = tuple(range(low, high + 1))
        else:
            values = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"n_units = {text!r}: give N, LOW..HIGH or a list N,N,...") from None
    if not values or any(not 1 <= v <= MAX_UNITS for v in values):
        raise ValueError(f"n_units = {text!r}: numbers of units are between 1 and {MAX_UNITS}")
    return values


# ----------------------------------------------------------------------------- results


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


# ----------------------------------------------------------------------------- lookup


def lookup(
    dataset: str | Path,
    target: ArrayLike,
    *,
    columns: Sequence[str] = DEFAULT_COLUMNS,
    scales: ArrayLike | None = None,
    state: str | int | None = None,
    n_units: Sequence[int] | None = None,
    where: str | None = None,
    k: int = 10,
    refine: bool = False,
    constraints: Mapping | None = None,
    tol: float = 1e-6,
    index: LookupIndex | None = None,
    rebuild: bool = True,
    max_evaluations: int = 60,
    verify: bool = True,
    constants: ConstantsSet | None = None,
) -> LookupResult:
    """Designs of a sweep dataset whose outputs are nearest to ``target``, verified.

    Parameters
    ----------
    dataset : path
        Sweep directory.
    target : array_like of shape (d,)
        Wanted value of each column (mm for the tip).
    columns, scales
        Indexed columns and their scales (see :mod:`.lookup_index`).
    state : None, "all-inverted", a bit string or an int
        Only rows of this state (default: any state the dataset holds).
    n_units : sequence of int, optional
        Only designs with these numbers of units.
    where : str, optional
        Only rows passing this :meth:`pandas.DataFrame.query` expression over the dataset's
        columns (e.g. ``"stiffness > 0.05 and t < 0.8"``).
    k : int
        Number of candidates.
    refine : bool
        Polish each candidate with the exact model until the target is met to ``tol``.
    constraints : mapping, optional
        Constraints of the refinement (:func:`~.refine.variables_for`), inside the job's box.
    tol : float
        Target tolerance, in the scaled units (mm for the tip).
    index : LookupIndex, optional
        An index to use (it must match the dataset: a stale one raises StaleIndexError);
        default: :func:`~.lookup_index.open_index`.
    rebuild : bool
        Rebuild a stale saved index (default) instead of raising StaleIndexError.
    max_evaluations : int
        Model evaluations per refinement.
    verify : bool
        Check every chunk read (index build, ``where``, candidate designs) against the
        manifest's SHA-256 (the default; ``False`` reads only the needed columns).
    constants : ConstantsSet, optional
        The constants set the candidates are re-solved under; it must be the dataset's
        (:meth:`~dpfexplore.sweep.datasets.DatasetInfo.constants_set`), which is the default.

    Raises
    ------
    StoreError
        ``dataset`` is missing or not a sweep directory; ``constants`` is not the dataset's
        set, or the dataset's set cannot be found (naming both).
    StaleIndexError
        The given index is stale or names rows the dataset does not hold there; with
        ``rebuild=False``, the saved one is stale, unreadable or fails a check.
    ValueError
        Naming the argument: unknown column, target of the wrong length, no usable rows, no
        rows left by the filters, a bad ``where``, a column that cannot be refined, bad
        constraints.
    """
    start = time.perf_counter()
    info = dataset_info(dataset)
    constants = info.constants_set(constants)  # before any work: a wrong set is refused
    notes = [info.note] if info.note else []
    if info.model_version != MODEL_VERSION:
        notes.append(
            f"the dataset was written by model version {info.model_version!r}; designs are "
            f"re-solved by this model ({MODEL_VERSION!r}), whose outputs may differ from the "
            "dataset's"
        )
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol = {tol!r}: must be finite and > 0")
    if where:  # a filter is checked before the index is opened or built
        parse_filter(where, read_schema(dataset))
    columns = tuple(columns)
    target = np.asarray(target, dtype=float).reshape(-1)
    if target.shape != (len(columns),) or not np.all(np.isfinite(target)):
        raise ValueError(
            f"target = {target.tolist()!r}: need {len(columns)} finite values, one per column "
            f"({', '.join(columns)})"
        )
    if constraints and not refine:
        raise ValueError("constraints apply to the refinement: ask for refine=True (--refine)")
    if refine:
        for name in columns:
            if name not in REFINABLE_COLUMNS:
                raise ValueError(
                    f"column {name!r}: cannot be refined (no model sensitivity); refinable: "
                    f"{', '.join(REFINABLE_COLUMNS)}"
                )
    origin = None
    if index is None:
        index, origin = open_index(
            dataset, columns, scales, rebuild=rebuild, info=info, verify=verify
        )
        if origin.reason:
            notes.append(f"lookup index {origin.action}: {origin.reason}")
    else:
        index.check(info)
        if index.columns != columns:
            raise ValueError(f"index over {index.columns}, asked for {columns}")
        if scales is not None:
            index = index.with_scales(scales)
    if len(index) == 0:
        raise ValueError(
            f"{dataset}: no usable rows (status ok and finite {', '.join(columns)}) in "
            f"{info.rows_committed} committed rows"
        )
    mask = None
    if where:
        keys = read_results(dataset, columns=["design_id", "requested"], where=where, verify=verify)
        mask = mask_of(index, {c: keys[c].to_numpy() for c in ("design_id", "requested")})
    for attempt in (0, 1):
        t0 = time.perf_counter()
        # The distances are the index's; each candidate's is computed again from its re-read row.
        _, rows = index.query(target, k, n_units=n_units, state=state, mask=mask)
        query_seconds = time.perf_counter() - t0
        if rows.size == 0:
            raise ValueError(
                f"no indexed rows match state = {state!r}, n_units = "
                f"{list(n_units) if n_units is not None else 'any'}, where = {where!r} "
                f"(the dataset has N = {list(index.n_values)})"
            )
        try:
            batch, source_values = _read_rows(
                index, rows, info=info, verify=verify, constants=constants
            )
            break
        except StaleIndexError as exc:
            # A saved index that passed its checks yet names rows the chunks do not hold there
            # (a file edited with its checksum recomputed): rebuild it once and ask again.
            if attempt or origin is None or origin.action != "loaded":
                raise
            index, origin = open_index(
                dataset,
                columns,
                scales,
                rebuild=rebuild,
                info=info,
                verify=verify,
                discard=exc.reason,
            )
            notes.append(f"lookup index {origin.action}: {origin.reason}")
            if where:
                mask = mask_of(index, {c: keys[c].to_numpy() for c in ("design_id", "requested")})
    states = index.requested[rows]
    refinements: list[Refinement | None] = [None] * rows.size
    designs = [batch.design(i) for i in range(rows.size)]
    if refine:
        space = parse_job(info.job).space
        for i, design in enumerate(designs):
            variables = variables_for(space, design, constraints)
            refinements[i] = refine_design(
                design,
                int(states[i]),
                target,
                variables=variables,
                columns=index.columns,
                scales=index.scales,
                tol=tol,
                max_evaluations=max_evaluations,
            )
            designs[i] = refinements[i].design
    candidates = _verified(
        designs, states, rows, source_values, index, target, tol, refinements, verify
    )
    candidates.sort(key=lambda c: (STATUS_ORDER.index(c.status), _sort_error(c.error)))
    candidates, merged = _merge_duplicates(candidates)
    if merged:
        notes.append(
            f"{merged} candidate{'s were' if merged > 1 else ' was'} the same design in the same "
            "state as a better one and merged into it (its also_from lists their design_ids)"
        )
    if refine:
        reachable = any(c.status == "ok" for c in candidates)
        if not reachable:
            best = candidates[0]
            tip_only = set(columns) == {"tip_x", "tip_y"} and np.all(index.scales == 1.0)
            away = f"{best.error:.4g} mm" if tip_only else f"{best.error:.4g} (scaled distance)"
            notes.append(
                f"target not reached to {tol:g}: the nearest design found is {away} from it "
                f"(N = {best.design.n_units}, state {best.state}, status {best.status})"
            )
    else:
        reachable = any(c.met for c in candidates)
        if not reachable:
            best = candidates[0]
            notes.append(
                f"target not met to {tol:g}: the nearest dataset design is {best.error:.4g} "
                "away from it; --refine polishes the candidates with the exact model"
            )
    result = LookupResult(
        target=target,
        columns=columns,
        scales=index.scales,
        tol=float(tol),
        candidates=candidates,
        refined=refine,
        reachable=reachable,
        dataset=info,
        index_origin=origin,
        index_rows=len(index),
        query_seconds=query_seconds,
        seconds=time.perf_counter() - start,
        notes=notes,
        state=state,
        n_units=tuple(n_units) if n_units is not None else None,
        where=where,
        index=index,
        verified=verify,
    )
    notes.append(_provenance_note(result.provenance))
    return result


def _provenance_note(provenance: Mapping[str, str]) -> str:
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


def _design_vector(design: Design) -> NDArray[np.float64]:
    values = design.to_dict()
    values.pop("name", None)
    return np.concatenate([np.atleast_1d(np.asarray(v, dtype=float)) for v in values.values()])


def _merge_duplicates(candidates: list[Candidate]) -> tuple[list[Candidate], int]:
    """Candidates (best first) without repeats, and how many were merged.

    Two candidates repeat when they have the same state and the same dataset row or the same
    design (every parameter within :data:`_SAME_DESIGN_ATOL`); the later one is merged into the
    earlier (its design_id goes to :attr:`Candidate.also_from`).
    """
    kept: list[Candidate] = []
    vectors: list[NDArray] = []
    merged = 0
    for c in candidates:
        vector = _design_vector(c.design)
        for j, k in enumerate(kept):
            same_row = k.design_id == c.design_id
            same_design = vector.shape == vectors[j].shape and bool(
                np.all(np.abs(vector - vectors[j]) <= _SAME_DESIGN_ATOL)
            )
            if k.state == c.state and (same_row or same_design):
                kept[j] = replace(k, also_from=(*k.also_from, c.design_id))
                merged += 1
                break
        else:
            kept.append(c)
            vectors.append(vector)
    return kept, merged


def _sort_error(error: float) -> float:
    return error if np.isfinite(error) else np.inf


def designs_of(
    index: LookupIndex,
    rows: NDArray[np.int64],
    *,
    info: DatasetInfo | None = None,
    verify: bool = True,
) -> DesignBatch:
    """The designs of index rows, read from their chunk files (the design columns).

    ``verify`` checks each file read against the manifest's SHA-256 first.

    Raises
    ------
    StaleIndexError
        A row read back is not the one the index names (another design_id or state), or the
        index names a chunk the dataset does not commit.
    """
    return _read_rows(index, rows, info=info, verify=verify)[0]


def _read_rows(
    index: LookupIndex,
    rows: NDArray[np.int64],
    *,
    info: DatasetInfo | None = None,
    verify: bool = True,
    constants: ConstantsSet | None = None,
) -> tuple[DesignBatch, NDArray[np.float64]]:
    """The designs and the indexed columns' values of index rows, read from their chunks.

    Each row's design_id, requested state and status are read with it and must be the
    index's (status ``ok``): the index only says where to look, the chunk says what is there.
    The designs carry ``constants``, by default the dataset's own set.
    """
    info = info or dataset_info(index.root)
    constants = info.constants_set(constants)
    index.check(info)
    schema = read_schema(index.root)
    max_units = sum(1 for name in schema.names if re.fullmatch(r"H_\d+", name))
    per_unit = [f"{p}_{k}" for p in ("H", "U_L", "U_sep") for k in range(1, max_units + 1)]
    shared = ["t", "t_lim", "E", "nu", "r_b", "t_ch"]
    identity = ["design_id", "requested", "status"]
    wanted = list(dict.fromkeys(["n_units", *identity, *per_unit, *shared, *index.columns]))
    m = rows.size
    arrays = {p: np.full((m, MAX_UNITS), np.nan) for p in ("H", "U_L", "U_sep")}
    arrays.update({name: np.empty(m) for name in shared})
    n_units = np.empty(m, dtype=np.int64)
    values = np.full((m, len(index.columns)), np.nan)
    files = index.file[rows]
    for f in np.unique(files):
        pick = np.flatnonzero(files == f)
        source = info.open_chunk(index.files[f], verify=verify)
        table = pq.read_table(source, columns=wanted, schema=schema)
        positions = index.row[rows[pick]]
        if positions.size and (positions.min() < 0 or positions.max() >= table.num_rows):
            raise _row_mismatch(index, f, int(positions.max()))
        table = table.take(positions)
        got = {name: table.column(name).to_numpy(zero_copy_only=False) for name in identity}
        bad = np.flatnonzero(
            (got["design_id"] != index.design_id[rows[pick]])
            | (got["requested"] != index.requested[rows[pick]])
            | (got["status"] != st.OK)
        )
        if bad.size:
            raise _row_mismatch(index, f, int(positions[bad[0]]))
        n_units[pick] = table.column("n_units").to_numpy()
        for p in ("H", "U_L", "U_sep"):
            for k in range(1, max_units + 1):
                arrays[p][pick, k - 1] = table.column(f"{p}_{k}").to_numpy(zero_copy_only=False)
        for name in shared:
            arrays[name][pick] = table.column(name).to_numpy()
        for j, name in enumerate(index.columns):
            # nulls (a per-unit column past the design's N) read as NaN
            column = table.column(name).cast("float64").fill_null(np.nan)
            values[pick, j] = column.to_numpy(zero_copy_only=False)
    return DesignBatch(n_units=n_units, **arrays, constants=constants), values


def _row_mismatch(index: LookupIndex, f: int, row: int) -> StaleIndexError:
    reason = (
        f"its rows do not match the dataset's ({index.files[f]} row {row} is not the design "
        "and state it records)"
    )
    return StaleIndexError(f"{index.root}: the lookup index of {index.columns}: {reason}", reason)


def _verified(
    designs, states, rows, source_values, index, target, tol, refinements, verify
) -> list[Candidate]:
    """Re-solve every design in one batch and assemble the candidates.

    ``source_values`` are the indexed columns as re-read from the rows' chunks.
    """
    batch = DesignBatch.from_designs(designs)
    cols = solve_batch(
        batch, [int(s) for s in states], stiffness=True, min_eig="min_eig" in index.columns
    )
    tip_cols = [index.columns.index(c) for c in ("tip_x", "tip_y") if c in index.columns]
    reread = REREAD if verify else REREAD_UNVERIFIED
    out = []
    for i, design in enumerate(designs):
        n = design.n_units
        code = int(cols["status"][i])
        refinement = refinements[i]
        # Columns the model computes come from the solve; others (reset times, ...) from the
        # dataset row, which describes the unrefined design only.
        provenance = tuple(
            RESOLVED if c in RESOLVED_COLUMNS else (reread if refinement is None else "none")
            for c in index.columns
        )
        values = np.array(
            [
                cols[c][i]
                if kind == RESOLVED
                else (source_values[i, j] if kind != "none" else np.nan)
                for j, (c, kind) in enumerate(zip(index.columns, provenance, strict=True))
            ]
        )
        error = float(np.linalg.norm((values - target) / index.scales))
        tip = np.array([cols["tip_x"][i], cols["tip_y"][i]])
        error_mm = float(np.linalg.norm(tip - target[tip_cols])) if len(tip_cols) == 2 else None
        met = bool(code == st.OK and error <= tol)
        if code == st.OK:
            # "ok" says the target is met, refined or not: a 26 mm miss labelled "ok" read as
            # a match
            status = (
                "ok"
                if met
                else (
                    refinement.status
                    if refinement is not None and refinement.status != "ok"
                    else "not_met"
                )
            )
        elif code == st.COLLAPSED:
            status = "collapsed"
        else:
            status = "failed"
        found = int(cols["found"][i])
        out.append(
            Candidate(
                design=design,
                state=state_string(int(states[i]), n),
                found=state_string(found, n) if found >= 0 else "",
                status=status,
                values=values,
                tip=tip,
                stiffness=float(cols["stiffness"][i]),
                error=error,
                error_mm=error_mm,
                met=met,
                refined=refinement is not None,
                design_id=int(index.design_id[rows[i]]),
                source_distance=float(np.linalg.norm((source_values[i] - target) / index.scales)),
                source_values=source_values[i],
                fitted_range=design.in_fitted_range,
                fitted_range_note=design.fitted_range_note,
                refinement=refinement,
                provenance=provenance,
            )
        )
    return out


# ----------------------------------------------------------------------------- reachable region


def reachable_tips(
    index: LookupIndex, n_units: Sequence[int] | None = None, state: str | int | None = None
) -> dict[int, NDArray]:
    """Tip positions (mm) of the usable rows per ``N``: the region the dataset reaches.

    Taken from the index when it holds the tip; otherwise read from the dataset (the tip
    columns of ``ok`` rows passing the same filters).
    """
    if index.columns[:2] == ("tip_x", "tip_y") or {"tip_x", "tip_y"} <= set(index.columns):
        cx, cy = index.columns.index("tip_x"), index.columns.index("tip_y")
        out: dict[int, list] = {}
        for key, part in index.slices(n_units, state):
            out.setdefault(key[0], []).append(index.points[part][:, [cx, cy]])
        return {n: np.concatenate(parts) for n, parts in sorted(out.items())}
    frame = read_results(index.root, columns=["n_units", "requested", "status", "tip_x", "tip_y"])
    frame = frame[frame["status"] == st.OK]
    keep = np.zeros(len(frame), dtype=bool)
    n_all = frame["n_units"].to_numpy().astype(np.int64)
    req = frame["requested"].to_numpy()
    for key, _ in index.slices(n_units, state):
        keep |= (n_all == key[0]) & ((req == key[1]) if len(key) == 2 else True)
    frame = frame[keep]
    return {
        int(n): part[["tip_x", "tip_y"]].to_numpy(float)
        for n, part in frame.groupby("n_units", sort=True)
    }
