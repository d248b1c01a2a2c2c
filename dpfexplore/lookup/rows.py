"""The rows of a lookup: designs read back from their chunks, re-solved, and merged.

The index only says where to look: :func:`read_rows` reads each candidate's design and indexed
values from its chunk (through a SHA-256 check unless told not to) and refuses a row that is not
the one the index names; :func:`verified_candidates` re-solves every design in one batch and
assembles the :class:`~.results.Candidate` s; :func:`merge_duplicates` reports a design once.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pyarrow.parquet as pq
from numpy.typing import NDArray

from ..model import status as st
from ..model.constants_set import ConstantsSet
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS
from ..solvers.statics import solve_batch, state_string
from ..sweep.storage.datasets import DatasetInfo, dataset_info
from ..sweep.storage.store import read_schema
from .index import LookupIndex, StaleIndexError
from .results import REREAD, REREAD_UNVERIFIED, RESOLVED, RESOLVED_COLUMNS, Candidate

__all__ = ["designs_of", "merge_duplicates", "read_rows", "sort_error", "verified_candidates"]

#: Two designs whose parameters (mm, 1, MPa) differ by no more than this are the same design.
_SAME_DESIGN_ATOL = 1e-9


def _design_vector(design: Design) -> NDArray[np.float64]:
    values = design.to_dict()
    values.pop("name", None)
    return np.concatenate([np.atleast_1d(np.asarray(v, dtype=float)) for v in values.values()])


def merge_duplicates(candidates: list[Candidate]) -> tuple[list[Candidate], int]:
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


def sort_error(error: float) -> float:
    """``error`` as a sort key: NaN (no error, the state does not exist) sorts last."""
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
    return read_rows(index, rows, info=info, verify=verify)[0]


def read_rows(
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


def verified_candidates(
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
