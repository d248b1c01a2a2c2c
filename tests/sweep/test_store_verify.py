"""Verified reads: a chunk changed after it was committed is an error naming the chunk."""

from __future__ import annotations

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
from sweep_helpers import UnitConstantsEvaluator, make_job

from dpfexplore.cli import main
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage import store


@pytest.fixture
def swept(tmp_path):
    out = tmp_path / "out"
    run_sweep(make_job(), out, evaluator=UnitConstantsEvaluator(), chunk_size=20)
    return out


def chunk_of(out, index=1):
    records = sorted(store.read_manifest(out).chunks.values(), key=lambda r: (r.n_units, r.index))
    return out / records[index].path


def test_a_chunk_altered_in_place_at_the_same_size_is_named(swept):
    path = chunk_of(swept)
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 16] = bytes(255 - b for b in data[middle : middle + 16])
    path.write_bytes(bytes(data))  # same size: only a checksum can tell
    with pytest.raises(store.StoreError, match=rf"chunk {path}: SHA-256 differs"):
        store.read_results(swept)
    with pytest.raises(store.StoreError, match=str(path)):
        store.open_dataset(swept)


def test_a_rewritten_chunk_with_changed_values_is_caught_unless_asked_not_to(swept, capsys):
    path = chunk_of(swept)
    before = store.read_results(swept)
    table = pq.read_table(path)
    k_b = table.column("k_b")
    table = table.set_column(
        table.column_names.index("k_b"), "k_b", pc.multiply(k_b, pa.scalar(1.5))
    )
    pq.write_table(table, path, compression="zstd")
    with pytest.raises(store.StoreError, match=rf"chunk {path}: size \d+ != \d+ bytes"):
        store.read_results(swept, columns=["k_b"])
    # the explicit opt-out reads what is there, changed values included
    after = store.read_results(swept, verify=False)
    assert (after["k_b"] != before["k_b"]).sum() == table.num_rows

    assert main(["query", str(swept), "--columns", "k_b"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "--no-verify" in err[0]
    assert main(["query", str(swept), "--columns", "k_b", "--no-verify"]) == 0
    assert f"({len(before)} rows)" in capsys.readouterr().out


def test_intact_chunks_read_the_same_with_and_without_verification(swept):
    verified = store.read_results(swept, where="unit == 2", columns=["design_id", "k_b"])
    unverified = store.read_results(
        swept, where="unit == 2", columns=["design_id", "k_b"], verify=False
    )
    assert verified.equals(unverified) and len(verified) > 0


def test_query_on_a_missing_directory_says_so(tmp_path, capsys):
    assert main(["query", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"dpfexplore query: error: {tmp_path / 'nowhere'}: no such directory"
