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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model import status as st
from ..model.constants_set import ConstantsSet
from ..model.design import DesignBatch
from ..model.domain import MAX_UNITS
from ..model.version import MODEL_VERSION
from ..sweep.job_file import recorded_space
from ..sweep.storage.datasets import DatasetInfo, dataset_info
from ..sweep.storage.row_filter import parse_filter
from ..sweep.storage.store import read_results, read_schema
from .index import DEFAULT_COLUMNS, LookupIndex, StaleIndexError, mask_of
from .polish import REFINABLE_COLUMNS, Refinement, variables_for
from .polish import refine as refine_design
from .results import (
    RESOLVED_COLUMNS,
    STATUS_ORDER,
    VERIFIED_NOTE,
    Candidate,
    LookupResult,
    provenance_note,
)
from .rows import designs_of, read_rows, sort_error, verified_candidates
from .rows import merge_duplicates as _merge_duplicates
from .store import IndexOrigin, open_index

__all__ = [
    "RESOLVED_COLUMNS",
    "VERIFIED_NOTE",
    "Candidate",
    "LookupResult",
    "PolishOptions",
    "RowFilter",
    "designs_of",
    "lookup",
    "parse_n_units",
    "reachable_tips",
]

logger = logging.getLogger(__name__)


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


# ----------------------------------------------------------------------------- options


@dataclass(frozen=True)
class RowFilter:
    """The rows a lookup considers: ``lookup``'s ``state``, ``n_units`` and ``where``."""

    state: str | int | None = None
    n_units: Sequence[int] | None = None
    where: str | None = None


def _filter_text(filters: RowFilter) -> str:
    """The filters that were given, as a message names them: ``n_units = 4..6, where = t < 0.8``."""
    given = []
    if filters.state is not None:
        given.append(f"state = {filters.state}")
    if filters.n_units is not None:
        n = sorted(int(v) for v in filters.n_units)
        span = len(n) > 2 and n == list(range(n[0], n[-1] + 1))
        given.append(
            f"n_units = {n[0]}..{n[-1]}" if span else f"n_units = {', '.join(map(str, n))}"
        )
    if filters.where is not None:
        given.append(f"where = {filters.where}")
    return ", ".join(given) if given else "(no filter)"


@dataclass(frozen=True)
class PolishOptions:
    """How a lookup polishes its candidates with the exact model (``lookup(refine=True)``).

    Attributes
    ----------
    constraints : mapping or None
        Constraints of the refinement (:func:`~.polish.variables_for`).
    tol : float
        Target tolerance, in the scaled units (mm for the tip); also what "met" means unpolished.
    max_evaluations : int
        Model evaluations per refinement.
    """

    constraints: Mapping | None = None
    tol: float = 1e-6
    max_evaluations: int = 60


@dataclass(frozen=True)
class _Source:
    """The dataset a lookup reads, and how: its info, constants set, checks, index and columns."""

    path: str | Path
    info: DatasetInfo
    constants: ConstantsSet
    verify: bool
    rebuild: bool
    columns: tuple[str, ...]
    scales: ArrayLike | None


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
        (:meth:`~dpfexplore.sweep.storage.datasets.DatasetInfo.constants_set`), which is the
        default.

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

    Notes
    -----
    The stages, each a function of its own: check the query (:func:`_checked_query`), open the
    index (:func:`_index_for`), take the nearest rows and read them back
    (:func:`_nearest_rows`), polish them (:func:`_polish`), re-solve every design
    (:func:`~.rows.verified_candidates`), merge repeats and say whether the target is met
    (:func:`_reachable`). The filters travel as one :class:`RowFilter`, the polish settings as
    one :class:`PolishOptions`.
    """
    start = time.perf_counter()
    info = dataset_info(dataset)
    constants = info.constants_set(constants)  # before any work: a wrong set is refused
    filters = RowFilter(state=state, n_units=n_units, where=where)
    polish = PolishOptions(constraints=constraints, tol=tol, max_evaluations=max_evaluations)
    notes = _dataset_notes(info)
    columns, target = _checked_query(dataset, columns, target, filters, polish, refine)
    source = _Source(dataset, info, constants, verify, rebuild, columns, scales)
    index, origin = _index_for(source, index, notes)
    index, origin, rows, batch, source_values, query_seconds = _nearest_rows(
        source, index, origin, target, k, filters, notes
    )
    states = index.requested[rows]
    designs = [batch.design(i) for i in range(rows.size)]
    refinements: list[Refinement | None] = [None] * rows.size
    if refine:
        refinements = _polish(source, designs, states, target, index, polish)
        designs = [r.design for r in refinements]
    candidates = verified_candidates(
        designs, states, rows, source_values, index, target, tol, refinements, verify
    )
    candidates.sort(key=lambda c: (STATUS_ORDER.index(c.status), sort_error(c.error)))
    candidates, merged = _merge_duplicates(candidates)
    if merged:
        notes.append(
            f"{merged} candidate{'s were' if merged > 1 else ' was'} the same design in the same "
            "state as a better one and merged into it (its also_from lists their design_ids)"
        )
    reachable = _reachable(candidates, refine, columns, index, tol, notes)
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
    notes.append(provenance_note(result.provenance))
    return result


def _dataset_notes(info: DatasetInfo) -> list[str]:
    """What a user must know about the dataset itself (incomplete, another model version)."""
    notes = [info.note] if info.note else []
    if info.model_version != MODEL_VERSION:
        notes.append(
            f"the dataset was written by model version {info.model_version!r}; designs are "
            f"re-solved by this model ({MODEL_VERSION!r}), whose outputs may differ from the "
            "dataset's"
        )
    return notes


def _checked_query(
    dataset, columns, target, filters: RowFilter, polish: PolishOptions, refine: bool
) -> tuple[tuple[str, ...], NDArray]:
    """The columns and the target, checked with the options before any index is opened."""
    tol = polish.tol
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol = {tol!r}: must be finite and > 0")
    if filters.where:  # a filter is checked before the index is opened or built
        parse_filter(filters.where, read_schema(dataset))
    columns = tuple(columns)
    target = np.asarray(target, dtype=float).reshape(-1)
    if target.shape != (len(columns),) or not np.all(np.isfinite(target)):
        raise ValueError(
            f"target = {target.tolist()!r}: need {len(columns)} finite values, one per column "
            f"({', '.join(columns)})"
        )
    if polish.constraints and not refine:
        raise ValueError("constraints apply to the refinement: ask for refine=True (--refine)")
    if refine:
        for name in columns:
            if name not in REFINABLE_COLUMNS:
                raise ValueError(
                    f"column {name!r}: cannot be refined (no model sensitivity); refinable: "
                    f"{', '.join(REFINABLE_COLUMNS)}"
                )
    return columns, target


def _index_for(
    source: _Source, index: LookupIndex | None, notes: list[str]
) -> tuple[LookupIndex, IndexOrigin | None]:
    """The saved (or rebuilt) index of ``columns``, or the caller's, checked against the dataset."""
    columns, scales = source.columns, source.scales
    origin = None
    if index is None:
        index, origin = open_index(
            source.path,
            columns,
            scales,
            rebuild=source.rebuild,
            info=source.info,
            verify=source.verify,
        )
        if origin.reason:
            notes.append(f"lookup index {origin.action}: {origin.reason}")
    else:
        index.check(source.info)
        if index.columns != columns:
            raise ValueError(f"index over {index.columns}, asked for {columns}")
        if scales is not None:
            index = index.with_scales(scales)
    if len(index) == 0:
        raise ValueError(
            f"{source.path}: no usable rows (status ok and finite {', '.join(columns)}) in "
            f"{source.info.rows_committed} committed rows"
        )
    return index, origin


def _nearest_rows(
    source: _Source,
    index: LookupIndex,
    origin: IndexOrigin | None,
    target: NDArray,
    k: int,
    filters: RowFilter,
    notes: list[str],
) -> tuple[LookupIndex, IndexOrigin | None, NDArray, DesignBatch, NDArray, float]:
    """The ``k`` nearest rows passing the filters, their designs and values read back.

    A saved index that passed its checks yet names rows the chunks do not hold there (a file
    edited with its checksum recomputed) is rebuilt once and asked again.

    Returns
    -------
    index, origin
        The index that answered (rebuilt or not).
    rows : ndarray of int
    batch : DesignBatch
        The rows' designs.
    source_values : ndarray of shape (k, d)
        The indexed columns re-read from the rows' chunks.
    query_seconds : float
        The nearest-neighbour query alone.
    """
    mask = keys = None
    if filters.where:
        keys = read_results(
            source.path,
            columns=["design_id", "requested"],
            where=filters.where,
            verify=source.verify,
        )
        mask = mask_of(index, {c: keys[c].to_numpy() for c in ("design_id", "requested")})
    for attempt in (0, 1):
        t0 = time.perf_counter()
        # The distances are the index's; each candidate's is computed again from its re-read row.
        _, rows = index.query(target, k, n_units=filters.n_units, state=filters.state, mask=mask)
        query_seconds = time.perf_counter() - t0
        if rows.size == 0:
            raise ValueError(
                f"no indexed rows match {_filter_text(filters)} "
                f"(the dataset has N = {', '.join(str(int(n)) for n in index.n_values)})"
            )
        try:
            batch, source_values = read_rows(
                index, rows, info=source.info, verify=source.verify, constants=source.constants
            )
            return index, origin, rows, batch, source_values, query_seconds
        except StaleIndexError as exc:
            if attempt or origin is None or origin.action != "loaded":
                raise
            index, origin = open_index(
                source.path,
                source.columns,
                source.scales,
                rebuild=source.rebuild,
                info=source.info,
                verify=source.verify,
                discard=exc.reason,
            )
            notes.append(f"lookup index {origin.action}: {origin.reason}")
            if keys is not None:
                mask = mask_of(index, {c: keys[c].to_numpy() for c in ("design_id", "requested")})
    raise AssertionError("unreachable")  # pragma: no cover


def _polish(
    source: _Source, designs, states, target, index: LookupIndex, polish: PolishOptions
) -> list[Refinement]:
    """Each candidate polished with the exact model inside the job's box and the constraints."""
    space = recorded_space(source.info.job)
    out = []
    for design, state in zip(designs, states, strict=True):
        variables = variables_for(space, design, polish.constraints)
        out.append(
            refine_design(
                design,
                int(state),
                target,
                variables=variables,
                columns=index.columns,
                scales=index.scales,
                tol=polish.tol,
                max_evaluations=polish.max_evaluations,
            )
        )
    return out


def _reachable(
    candidates: list[Candidate], refine: bool, columns, index: LookupIndex, tol, notes: list[str]
) -> bool:
    """Whether a candidate meets the target; if none does, a note on the nearest one."""
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
        return reachable
    reachable = any(c.met for c in candidates)
    if not reachable:
        best = candidates[0]
        notes.append(
            f"target not met to {tol:g}: the nearest dataset design is {best.error:.4g} "
            "away from it; --refine polishes the candidates with the exact model"
        )
    return reachable


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
