"""Parquet store: schema with units, atomic chunk commits, manifest, manifest-only readers."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from sweep_helpers import UnitConstantsEvaluator, make_job

from dpfexplore.model.version import MODEL_VERSION
from dpfexplore.sweep.chunks import ChunkTask, dataset_schema, evaluate_chunk
from dpfexplore.sweep.storage import store
from dpfexplore.sweep.storage.store import ChunkRecord, Manifest


@pytest.fixture
def spec():
    return make_job()


@pytest.fixture
def schema(spec):
    return dataset_schema(spec, UnitConstantsEvaluator())


def test_every_field_has_a_unit_and_a_description(schema):
    for f in schema:
        meta = f.metadata or {}
        assert meta.get(b"unit"), f.name
        assert meta.get(b"description"), f.name
    assert schema.field("H_3").metadata[b"unit"] == b"mm"
    assert schema.field("k_b").metadata[b"unit"] == b"N/mm"
    assert "H_4" not in schema.names  # per-unit columns up to the job's largest N


def test_dataset_metadata_holds_job_seed_and_versions(spec, schema):
    meta = store.schema_metadata(schema)
    assert meta["job"] == spec.to_dict()
    assert meta["seed"] == spec.seed
    assert meta["fingerprint"] == spec.fingerprint()
    assert meta["model_version"] == MODEL_VERSION
    assert {"numpy", "pyarrow", "dpfexplore", "python"} <= set(meta["versions"])


def test_per_unit_columns_are_null_past_n(spec, schema):
    table = evaluate_chunk(spec, UnitConstantsEvaluator(), schema, ChunkTask(2, 0, 0, 10))
    assert table.schema.equals(schema, check_metadata=True)
    frame = table.to_pandas()
    assert frame["H_3"].isna().all() and frame["U_sep_3"].isna().all()
    assert frame["H_2"].notna().all()
    assert len(frame) == 20  # two unit rows per design of 2 units


def _write_two_chunks(tmp_path, spec, schema):
    evaluator = UnitConstantsEvaluator()
    records = []
    for index, (start, stop) in enumerate([(0, 10), (10, 25)]):
        table = evaluate_chunk(spec, evaluator, schema, ChunkTask(2, index, start, stop))
        records.append(store.write_chunk(tmp_path, 2, index, start, stop, table))
    return records


def test_write_chunk_is_atomic_and_deterministic(tmp_path, spec, schema):
    first, _ = _write_two_chunks(tmp_path, spec, schema)
    path = tmp_path / "N02" / "part-000000.parquet"
    assert first.path == "N02/part-000000.parquet"
    assert first.bytes == path.stat().st_size
    assert first.sha256 == store.file_sha256(path)
    assert first.rows == pq.read_metadata(path).num_rows == 20
    assert not list(tmp_path.rglob("*.tmp"))
    # A retried chunk overwrites the same name with the same bytes: no duplicate.
    table = evaluate_chunk(spec, UnitConstantsEvaluator(), schema, ChunkTask(2, 0, 0, 10))
    again = store.write_chunk(tmp_path, 2, 0, 0, 10, table)
    assert again == first
    assert sorted(p.name for p in (tmp_path / "N02").iterdir()) == [
        "part-000000.parquet",
        "part-000001.parquet",
    ]


def test_file_carries_schema_metadata(tmp_path, spec, schema):
    _write_two_chunks(tmp_path, spec, schema)
    file_schema = pq.read_schema(tmp_path / "N02" / "part-000001.parquet")
    assert file_schema.field("k_b").metadata[b"unit"] == b"N/mm"
    assert store.schema_metadata(file_schema)["fingerprint"] == spec.fingerprint()


def _manifest(spec, records):
    return Manifest(
        fingerprint=spec.fingerprint(),
        job=spec.to_dict(),
        result_defining=spec.result_defining(),
        model_version=MODEL_VERSION,
        versions={},
        plan={2: 60, 3: 60},
        chunk_sizes={2: 10, 3: 10},
        chunks={r.path: r for r in records},
    )


def test_manifest_round_trip(tmp_path, spec, schema):
    records = _write_two_chunks(tmp_path, spec, schema)
    manifest = _manifest(spec, records)
    store.write_manifest(tmp_path, manifest)
    loaded = store.read_manifest(tmp_path)
    assert loaded == manifest
    assert loaded.n_rows == 50 and loaded.n_designs_committed == 25
    assert json.loads((tmp_path / store.MANIFEST).read_text())["format"] == store.FORMAT


def test_readers_use_only_manifest_listed_files(tmp_path, spec, schema):
    first, second = _write_two_chunks(tmp_path, spec, schema)
    store.write_common_metadata(tmp_path, schema)
    store.write_manifest(tmp_path, _manifest(spec, [first]))  # second: renamed, not committed
    (tmp_path / "N02" / ".part-000002.parquet.123-abc.tmp").write_bytes(b"half a file")
    frame = store.read_results(tmp_path)
    assert len(frame) == first.rows
    assert frame["sample"].max() == 9
    dataset = store.open_dataset(tmp_path)
    assert dataset.count_rows() == first.rows
    # pandas.read_parquet on the directory skips the temporary file (leading dot) and the
    # manifest, but does see uncommitted part files: it agrees with us once a sweep is complete.
    assert len(pd.read_parquet(tmp_path)) == first.rows + second.rows


def test_read_results_columns_and_where(tmp_path, spec, schema):
    records = _write_two_chunks(tmp_path, spec, schema)
    store.write_common_metadata(tmp_path, schema)
    store.write_manifest(tmp_path, _manifest(spec, records))
    frame = store.read_results(tmp_path, columns=["sample", "k_b"], where="unit == 2 and H_1 > 4")
    assert list(frame.columns) == ["sample", "k_b"]
    full = store.read_results(tmp_path)
    expected = full.query("unit == 2 and H_1 > 4")[["sample", "k_b"]].reset_index(drop=True)
    pd.testing.assert_frame_equal(frame, expected)
    assert len(frame) > 0
    with pytest.raises(KeyError, match="nope"):
        store.read_results(tmp_path, columns=["nope"])
    with pytest.raises(ValueError, match="--where"):
        store.read_results(tmp_path, where="unit ==")
    empty = store.read_results(tmp_path, where="unit > 100")
    assert len(empty) == 0 and "k_b" in empty.columns


def test_verify_chunk_detects_damage(tmp_path, spec, schema):
    record, _ = _write_two_chunks(tmp_path, spec, schema)
    assert store.verify_chunk(tmp_path, record) is None
    path = tmp_path / record.path
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    assert store.verify_chunk(tmp_path, record) == "checksum mismatch"
    assert store.verify_chunk(tmp_path, record, checksum=False) is None
    path.write_bytes(bytes(data[:-10]))
    assert "size" in store.verify_chunk(tmp_path, record)
    path.unlink()
    assert store.verify_chunk(tmp_path, record) == "missing"


def test_remove_leftovers_only_removes_temporaries(tmp_path, spec, schema):
    _write_two_chunks(tmp_path, spec, schema)
    (tmp_path / ".x.tmp").write_text("")
    (tmp_path / "N02" / ".part-000009.parquet.1-2.tmp").write_text("")
    removed = store.remove_leftovers(tmp_path)
    assert len(removed) == 2
    assert store.part_files(tmp_path) == ["N02/part-000000.parquet", "N02/part-000001.parquet"]


def test_table_from_columns_requires_every_field(schema):
    with pytest.raises(KeyError, match="design_id"):
        store.table_from_columns(schema, {}, n_units=np.array([], dtype=np.int64))


def test_status_labels_are_dictionary_encoded():
    schema = pa.schema([store.column("status_label", store.STATUS_TYPE, "1", "x")])
    table = store.table_from_columns(
        schema, {"status_label": np.array([0, 4, 1])}, n_units=np.ones(3)
    )
    assert table.column(0).to_pylist() == ["ok", "collapsed", "invalid_input"]


def test_reading_a_non_sweep_directory_fails_clearly(tmp_path):
    with pytest.raises(store.StoreError, match="not a sweep directory"):
        store.read_manifest(tmp_path)
    (tmp_path / store.MANIFEST).write_text("{")
    with pytest.raises(store.StoreError, match="unreadable manifest"):
        store.read_manifest(tmp_path)


def test_chunk_record_statuses_survive_json(spec):
    record = ChunkRecord("N02/part-000000.parquet", 2, 0, 0, 10, 10, 100, "ab", {"ok": 10})
    manifest = _manifest(spec, [record])
    assert Manifest.from_json(manifest.to_json()).chunks[record.path].statuses == {"ok": 10}
