"""Training data of the surrogates: sweep rows, the held-out split by design, held-out errors.

* :func:`load_training_data` reads only the columns a surrogate needs from a sweep dataset
  (:func:`dpfexplore.read_results`) and drops invalid designs.
* :func:`split_by_design` holds out whole designs, never single rows: a design's rows (one per
  requested state) share their parameters, so a row split would test on designs seen in
  training.
* :func:`held_out_errors` gives the median, 95th percentile and largest absolute error per output
  and per N (and the tip's Euclidean error when both tip coordinates are outputs).
* :func:`designs_from_rows` turns sweep rows back into a :class:`DesignBatch` for the exact model.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
from numpy.typing import NDArray

from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.design import PER_UNIT_FIELDS, SHARED_FIELDS, DesignBatch
from ..model.domain import MAX_UNITS
from ..sweep.storage.datasets import dataset_info
from ..sweep.storage.store import StoreError, read_manifest, read_results, read_schema

__all__ = [
    "TrainingData",
    "dataset_fingerprint",
    "designs_from_rows",
    "held_out_errors",
    "load_training_data",
    "output_columns",
    "split_by_design",
]

#: Columns that identify a row or describe its design: never outputs.
_NOT_OUTPUTS = {
    "design_id",
    "n_units",
    "sample",
    "requested",
    "found",
    "status",
    "n_iter",
    "dyn_status",
    "final_state",
    *SHARED_FIELDS,
}
#: Derived output: Euclidean distance between predicted and true tip (mm).
TIP = "tip"


def output_columns(schema: pa.Schema) -> list[str]:
    """Numeric columns of a sweep schema a surrogate can predict (not design or id columns)."""
    names = []
    for f in schema:
        stem = f.name.rsplit("_", 1)[0] if f.name[-1].isdigit() else f.name
        if f.name in _NOT_OUTPUTS or stem in PER_UNIT_FIELDS:
            continue
        if pa.types.is_floating(f.type):
            names.append(f.name)
    return names


def dataset_fingerprint(root: str | Path) -> dict[str, object]:
    """Identity of a sweep dataset's committed contents.

    Returns
    -------
    dict
        ``job_fingerprint`` (the job spec's fingerprint), ``model_version``, ``chunks_sha256``
        (SHA-256 over the manifest's committed chunk paths and their SHA-256: any change of the
        committed data changes it), ``rows`` and ``complete``.

    Raises
    ------
    dpfexplore.sweep.storage.store.StoreError
        If ``root`` is not a sweep directory.
    """
    manifest = read_manifest(root)
    digest = hashlib.sha256()
    for path, record in sorted(manifest.chunks.items()):
        digest.update(f"{path}:{record.sha256}\n".encode())
    recorded = manifest.result_defining.get("constants") or {
        "name": DEFAULT.name,
        "fingerprint": DEFAULT.fingerprint,
    }
    return {
        "job_fingerprint": manifest.fingerprint,
        "constants": dict(recorded),
        "model_version": manifest.model_version,
        "chunks_sha256": digest.hexdigest(),
        "rows": manifest.n_rows,
        "complete": manifest.complete,
    }


@dataclass(frozen=True)
class TrainingData:
    """Rows of valid designs of a sweep dataset, with the columns a surrogate needs.

    Attributes
    ----------
    root : Path
    frame : DataFrame
        ``design_id``, ``n_units``, ``requested``, ``status_label``, the design columns and the
        outputs; one row per design-state.
    outputs : tuple of str
    units : dict of str to str
        Physical unit of each output (from the dataset schema).
    fingerprint : dict
        :func:`dataset_fingerprint` of ``root``.
    constants : ConstantsSet
        The constants set the dataset's rows were computed under.
    """

    root: Path
    frame: pd.DataFrame
    outputs: tuple[str, ...]
    units: dict[str, str]
    fingerprint: dict[str, object]
    constants: ConstantsSet = DEFAULT

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Rows whose requested state exists (their outputs describe it)."""
        return (self.frame["status_label"] == "ok").to_numpy()


def load_training_data(
    root: str | Path, outputs: Sequence[str], *, constants: ConstantsSet | None = None
) -> TrainingData:
    """Read the design columns and ``outputs`` of a sweep dataset (only those columns).

    ``constants`` (a user's ``--constants``) must be the dataset's own set; the data carry that
    set either way (:meth:`~dpfexplore.sweep.storage.datasets.DatasetInfo.constants_set`).

    Raises
    ------
    ValueError
        For no outputs, an output that is not a numeric output column of the dataset, or a
        directory that is not a sweep dataset (the message names it).
    StoreError
        When ``constants`` is not the dataset's set, or the dataset's set cannot be found.
    """
    root = Path(root)
    try:
        schema = read_schema(root)
        fingerprint = dataset_fingerprint(root)
    except StoreError as exc:
        raise ValueError(str(exc)) from None
    outputs = list(dict.fromkeys(outputs))
    if not outputs:
        raise ValueError("outputs: none given")
    available = output_columns(schema)
    for name in outputs:
        if name not in available:
            raise ValueError(
                f"output {name!r}: not an output column of {root}; "
                f"choose from {', '.join(available)}"
            )
    max_n = max((k for k in range(1, MAX_UNITS + 1) if f"H_{k}" in schema.names), default=0)
    per_unit = [f"{name}_{k}" for name in PER_UNIT_FIELDS for k in range(1, max_n + 1)]
    columns = [
        "design_id",
        "n_units",
        "requested",
        "status_label",
        "problem",
        *per_unit,
        *SHARED_FIELDS,
        *outputs,
    ]
    frame = read_results(root, columns=columns)
    frame = frame[frame["problem"].isna()].drop(columns="problem").reset_index(drop=True)
    frame["status_label"] = frame["status_label"].astype(str)
    units = {}
    for name in outputs:
        meta = schema.field(name).metadata or {}
        units[name] = meta.get(b"unit", b"").decode()
    constants = dataset_info(root).constants_set(constants)
    return TrainingData(root, frame, tuple(outputs), units, fingerprint, constants)


def split_by_design(
    design_id: NDArray[np.integer],
    *,
    test_fraction: float,
    seed: int = 0,
    max_train_designs: int | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Row masks of a train / held-out split that keeps each design's rows together.

    Parameters
    ----------
    design_id : ndarray of int, shape (n_rows,)
    test_fraction : float
        Share of the designs held out, in (0, 1).
    seed : int
    max_train_designs : int, optional
        Train on at most this many of the other designs (randomly chosen).

    Returns
    -------
    train, test : ndarray of bool, shape (n_rows,)
        Disjoint; every row of a design is on the same side (or on neither, past the cap).
    """
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"test_fraction = {test_fraction}: must be in (0, 1)")
    if max_train_designs is not None and max_train_designs < 1:
        raise ValueError(f"max_train_designs = {max_train_designs}: must be >= 1")
    ids = np.unique(np.asarray(design_id))
    order = np.random.default_rng(seed).permutation(ids.size)
    n_test = max(1, round(test_fraction * ids.size))
    test_ids = ids[order[:n_test]]
    train_ids = ids[order[n_test:]][:max_train_designs]
    return np.isin(design_id, train_ids), np.isin(design_id, test_ids)


def held_out_errors(
    frame: pd.DataFrame, predicted: NDArray, outputs: Sequence[str]
) -> pd.DataFrame:
    """Absolute (and relative) errors of predictions per output and per N.

    Parameters
    ----------
    frame : DataFrame
        Held-out rows with ``n_units`` and the true ``outputs``.
    predicted : ndarray of shape (n_rows, len(outputs))
    outputs : sequence of str

    Returns
    -------
    DataFrame
        One row per output (plus ``tip``, the Euclidean tip error in mm, when ``tip_x`` and
        ``tip_y`` are outputs) and per N (plus ``"all"``): ``output``, ``n_units``, ``n``,
        ``median``, ``p95``, ``max`` (absolute, in the output's unit), ``median_rel``,
        ``p95_rel`` (relative to the true value's magnitude; NaN for the tip).
    """
    predicted = np.asarray(predicted, dtype=float).reshape(len(frame), len(outputs))
    truth = frame[list(outputs)].to_numpy(dtype=float)
    errors = {name: np.abs(predicted[:, j] - truth[:, j]) for j, name in enumerate(outputs)}
    relative = {name: errors[name] / np.abs(truth[:, j]) for j, name in enumerate(outputs)}
    if "tip_x" in outputs and "tip_y" in outputs:
        errors[TIP] = np.hypot(errors["tip_x"], errors["tip_y"])
        relative[TIP] = np.full(len(frame), np.nan)
    n_units = frame["n_units"].to_numpy()
    rows = []
    groups = [(int(n), n_units == n) for n in np.unique(n_units)]
    groups.append(("all", np.ones(len(frame), dtype=bool)))
    for name in [TIP, *outputs] if TIP in errors else outputs:
        for n, rows_n in groups:
            e, r = errors[name][rows_n], relative[name][rows_n]
            if e.size == 0:
                continue
            rows.append(
                {
                    "output": name,
                    "n_units": n,
                    "n": int(e.size),
                    "median": float(np.median(e)),
                    "p95": float(np.quantile(e, 0.95)),
                    "max": float(e.max()),
                    "median_rel": float(np.median(r)) if np.isfinite(r).any() else np.nan,
                    "p95_rel": float(np.quantile(r, 0.95)) if np.isfinite(r).any() else np.nan,
                }
            )
    return pd.DataFrame(rows)


def designs_from_rows(frame: pd.DataFrame, constants: ConstantsSet = DEFAULT) -> DesignBatch:
    """The designs of sweep rows (design columns of the sweep schema) as a batch.

    Per-unit columns missing from ``frame`` (units beyond its largest N) are NaN; the batch
    runs on ``constants`` (the rows' dataset's set).
    """
    n = len(frame)
    n_units = frame["n_units"].to_numpy(dtype=np.int64)
    names = [f"{name}_{k}" for name in PER_UNIT_FIELDS for k in range(1, MAX_UNITS + 1)]
    # One reindex and one conversion: reading the 36 columns one by one cost ~1 ms per call,
    # most of a single-design prediction.
    values = frame.reindex(columns=names).to_numpy(dtype=float, na_value=np.nan)
    values = values.reshape(n, len(PER_UNIT_FIELDS), MAX_UNITS)
    per_unit = {name: np.ascontiguousarray(values[:, j]) for j, name in enumerate(PER_UNIT_FIELDS)}
    shared = frame[list(SHARED_FIELDS)].to_numpy(dtype=float)
    return DesignBatch(
        n_units=n_units,
        **per_unit,
        **{name: shared[:, j].copy() for j, name in enumerate(SHARED_FIELDS)},
        constants=constants,
    )
