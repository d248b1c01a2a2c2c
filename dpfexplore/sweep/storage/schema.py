"""The schema of a sweep dataset: columns with units and descriptions, and the dataset metadata.

Every field carries its physical unit and a description in its Arrow field metadata (``unit``,
``description``; ``per_unit`` for the columns of unit ``k``), and the schema metadata key
``dpfexplore`` holds the job spec, seed, fingerprint, model version and package versions
(:func:`dataset_metadata`). :mod:`dpfexplore.sweep.storage.store` re-exports everything here.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
from numpy.typing import NDArray

from ...model import status as st
from ...model.version import MODEL_VERSION, package_versions
from ..space import JobSpec

__all__ = [
    "METADATA_KEY",
    "STATUS_LABELS",
    "STATUS_TYPE",
    "column",
    "dataset_metadata",
    "describe_schema",
    "design_fields",
    "schema_metadata",
    "table_from_columns",
    "with_dataset_metadata",
]

#: Identifies the layout of a sweep directory; bump when it changes incompatibly.
FORMAT = "dpfexplore-sweep/1"
#: Schema-metadata key of the dataset's JSON metadata.
METADATA_KEY = b"dpfexplore"


def column(
    name: str, dtype: pa.DataType, unit: str, description: str, *, per_unit: bool = False
) -> pa.Field:
    """An Arrow field with its physical unit and description in the field metadata.

    ``per_unit=True`` marks a column of unit ``k`` (``H_3``, ``reset_time_3``): it is null in
    rows of designs with fewer than ``k`` units.
    """
    metadata = {"unit": unit, "description": description}
    if per_unit:
        metadata["per_unit"] = "true"
    return pa.field(name, dtype, nullable=True, metadata=metadata)


#: Label of each status code, indexed by code (the codes are 0..n-1; Status(i) fails loudly
#: at import if that ever stops being true).
STATUS_LABELS = [st.Status(code).label for code in range(len(st.Status))]
STATUS_TYPE = pa.dictionary(pa.int8(), pa.string())

_VARIABLE_DOCS = {
    "H": ("mm", "dome height of unit {k}"),
    "U_L": ("mm", "unit length of unit {k}"),
    "U_sep": ("mm", "unit separation of unit {k}"),
}
_SHARED_DOCS = {
    "t": ("mm", "dome thickness"),
    "t_lim": ("mm", "limiting-layer thickness"),
    "E": ("MPa", "Young's modulus"),
    "nu": ("1", "Poisson ratio"),
    "r_b": ("mm", "dome base radius"),
    "t_ch": ("mm", "chamber wall thickness"),
}


def design_fields(max_units: int) -> list[pa.Field]:
    """Columns that identify and describe a design (repeated on each of its state rows)."""
    fields = [
        column(
            "design_id",
            pa.int64(),
            "1",
            "design number within the sweep: designs of smaller N first, then plan order",
        ),
        column("n_units", pa.int8(), "1", "number of units N"),
        column("sample", pa.int64(), "1", "index of the design in the sample plan of its N"),
    ]
    for name, (unit, text) in _VARIABLE_DOCS.items():
        fields += [
            column(f"{name}_{k}", pa.float64(), unit, text.format(k=k), per_unit=True)
            for k in range(1, max_units + 1)
        ]
    fields += [
        column(name, pa.float64(), unit, text) for name, (unit, text) in _SHARED_DOCS.items()
    ]
    fields.append(
        column(
            "problem",
            pa.string(),
            "1",
            "why the design is invalid (null for a valid design); see status",
        )
    )
    fields.append(
        column(
            "fitted_range",
            pa.bool_(),
            "1",
            "true when the design lies in the domain its constants set was fitted on (the "
            "dataset's constants metadata; the paper's set: H 3-5 mm, t 0.5-1 mm, E 5-40 MPa, "
            "r_b 5 mm); false: its results extrapolate the closed forms",
        )
    )
    return fields


def dataset_metadata(spec: JobSpec) -> dict[str, Any]:
    """The dataset-level metadata: job, seed, fingerprint, constants set, versions."""
    return {
        "format": FORMAT,
        "job": spec.to_dict(),
        "seed": spec.seed,
        "fingerprint": spec.fingerprint(),
        "constants": spec.result_defining()["constants"],
        "model_version": MODEL_VERSION,
        "versions": package_versions(),
    }


def with_dataset_metadata(schema: pa.Schema, metadata: Mapping[str, Any]) -> pa.Schema:
    """``schema`` carrying ``metadata`` as JSON under the ``dpfexplore`` key."""
    return schema.with_metadata({METADATA_KEY: json.dumps(metadata, sort_keys=True).encode()})


def schema_metadata(schema: pa.Schema) -> dict[str, Any]:
    """The JSON metadata a dataset schema carries (empty if none)."""
    raw = (schema.metadata or {}).get(METADATA_KEY)
    return json.loads(raw) if raw else {}


def describe_schema(schema: pa.Schema) -> pd.DataFrame:
    """One row per column: name, Arrow type, unit, description (for documentation)."""
    rows = []
    for f in schema:
        meta = {k.decode(): v.decode() for k, v in (f.metadata or {}).items()}
        rows.append(
            {
                "column": f.name,
                "type": str(f.type),
                "unit": meta.get("unit", ""),
                "description": meta.get("description", ""),
            }
        )
    return pd.DataFrame(rows)


def _unit_of_column(f: pa.Field) -> int | None:
    if not f.metadata or f.metadata.get(b"per_unit") != b"true":
        return None
    return int(f.name.rsplit("_", 1)[1])


def table_from_columns(
    schema: pa.Schema, columns: Mapping[str, Any], n_units: NDArray[np.integer]
) -> pa.Table:
    """Build a table of ``schema`` from row-aligned arrays.

    Parameters
    ----------
    schema : pyarrow.Schema
    columns : mapping of str to array_like
        One entry per field, all of the same length: a NumPy array, or a ready Arrow array of
        the field's type. A per-unit field ``name_k`` may come as one array ``name`` of shape
        ``(n_rows, MAX_UNITS)``. Status-label fields (``dictionary<int8, string>``) take the
        integer codes of :mod:`dpfexplore.model.status`; string fields take sequences of str/None.
    n_units : ndarray of int, shape (n_rows,)
        Units of each row's design: per-unit columns are null past it.

    Raises
    ------
    KeyError
        If a field of the schema has no array (the schema is the contract).
    """
    arrays = []
    n_units = np.asarray(n_units)
    for f in schema:
        unit = _unit_of_column(f)
        if f.name in columns:
            values = columns[f.name]
        elif unit is not None and f.name.rsplit("_", 1)[0] in columns:
            values = np.asarray(columns[f.name.rsplit("_", 1)[0]])[:, unit - 1]
        else:
            raise KeyError(f"no values for column {f.name!r}")
        if isinstance(values, (pa.Array, pa.ChunkedArray)):
            arrays.append(values if values.type == f.type else values.cast(f.type))
        elif f.type == STATUS_TYPE:
            codes = pa.array(np.asarray(values, dtype=np.int8), pa.int8())
            arrays.append(pa.DictionaryArray.from_arrays(codes, pa.array(STATUS_LABELS)))
        elif pa.types.is_string(f.type):
            arrays.append(pa.array(list(values), pa.string()))
        else:
            mask = (n_units < unit) if unit is not None else None
            arrays.append(pa.array(np.asarray(values), type=f.type, mask=mask))
    return pa.Table.from_arrays(arrays, schema=schema)
