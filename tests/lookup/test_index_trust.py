"""A saved lookup index is trusted only after every check: a tampered, damaged or crafted file
is rebuilt from the verified dataset (and the lookup still finds the true nearest design); an
index built from unverified reads is never saved; every reported value says whether the model
re-solved it or it was re-read from the verified dataset row; a design is reported once."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from sweep_helpers import make_job

from dpfexplore.cli import main
from dpfexplore.lookup.query import VERIFIED_NOTE, _merge_duplicates, lookup
from dpfexplore.lookup.store import (
    ARRAYS,
    arrays_checksum,
    index_path,
    load_index,
    open_index,
)
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage import store

TARGET = (30.0, 20.0)
TIP = ("tip_x", "tip_y")


@pytest.fixture(scope="module")
def inverted(tmp_path_factory):
    """N = 3, 4, all units inverted; 8 chunks of 10 designs."""
    spec = make_job(
        **{
            "job.name": "trust",
            "job.samples_per_n": 40,
            "job.chunk_size": 10,
            "space.n_units": [3, 4],
        }
    )
    path = tmp_path_factory.mktemp("trust") / "inv"
    run_sweep(spec, path)
    return spec, path


@pytest.fixture(scope="module")
def dynamic(tmp_path_factory):
    """N = 3, sequential states, with the pressure cycle simulated (snap and reset times)."""
    load = {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0}
    spec = make_job(
        **{
            "job.name": "dyn",
            "job.samples_per_n": 24,
            "job.chunk_size": 8,
            "space.n_units": [3],
            "compute.states": "sequential",
            "compute.reset_times": load,
        }
    )
    path = tmp_path_factory.mktemp("trust-dyn") / "dyn"
    run_sweep(spec, path)
    return path


def fresh(source, target):
    """A copy of a dataset without any saved index."""
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("_lookup*"))
    return target


def ok_rows(path):
    frame = store.read_results(path)
    return frame[frame["status_label"] == "ok"].reset_index(drop=True)


def nearest(path, target, columns=TIP):
    """(design_id, requested) of the row nearest ``target``, by brute force over the dataset."""
    frame = ok_rows(path)
    frame = frame[np.all(np.isfinite(frame[list(columns)].to_numpy(float)), axis=1)]
    d = np.linalg.norm(frame[list(columns)].to_numpy(float) - np.asarray(target), axis=1)
    row = frame.iloc[int(np.argmin(d))]
    return int(row.design_id), int(row.requested)


def best_of(result):
    return result.best.design_id, int(result.best.state, 2)


def rewrite(path, *, meta=None, arrays=None, rehash=False):
    """Edit a saved index file: ``meta(dict) -> dict | str``, ``arrays(dict) -> None``."""
    with np.load(path, allow_pickle=False) as data:
        content = {name: data[name] for name in data.files}
    if arrays is not None:
        arrays(content)
    record = json.loads(str(content["meta"]))
    if rehash:  # a careful forger recomputes the checksum of the arrays
        record["arrays_sha256"] = arrays_checksum(content)
    if meta is not None:
        record = meta(record)
    content["meta"] = np.array(record if isinstance(record, str) else json.dumps(record))
    with open(path, "wb") as fh:
        np.savez(fh, **content)


def far_row(content):
    """Position of the indexed row farthest from TARGET (so moving it changes the answer)."""
    return int(np.argmax(np.linalg.norm(content["points"] - np.asarray(TARGET), axis=1)))


def move_onto_target(content):
    content["points"][far_row(content)] = TARGET


def set_key(key, value):
    def edit(record):
        record[key] = value
        return record

    return edit


def drop_key(key):
    def edit(record):
        record.pop(key)
        return record

    return edit


def first_chunk_outside(record):
    record["chunks"][0]["path"] = "../elsewhere.parquet"
    return record


def swap_ids(content):
    ids = content["design_id"]
    ids[[0, -1]] = ids[[-1, 0]]


TAMPERS = {
    "points row moved onto the target": (dict(arrays=move_onto_target), "checksum"),
    "points of a shape that broadcasts": (
        dict(arrays=lambda c: c.update(points=np.ascontiguousarray(c["points"][:, :1]))),
        "shape",
    ),
    "points as float32": (
        dict(arrays=lambda c: c.update(points=c["points"].astype(np.float32)), rehash=True),
        "float32",
    ),
    "design_id array edited": (dict(arrays=swap_ids), "checksum"),
    "design_id array edited, checksum recomputed": (
        dict(arrays=swap_ids, rehash=True),
        "out of order",
    ),
    "ids shorter than points": (
        dict(arrays=lambda c: c.update(design_id=c["design_id"][:-1]), rehash=True),
        "shape",
    ),
    "chunk number out of range": (
        dict(arrays=lambda c: c["chunk_file"].__setitem__(0, 99), rehash=True),
        "does not list",
    ),
    "file path outside the dataset": (dict(meta=first_chunk_outside), "outside the dataset"),
    "meta JSON garbage": (dict(meta=lambda r: "{not json"), "unreadable"),
    "meta JSON a list": (dict(meta=lambda r: [1, 2]), "not a mapping"),
    "meta without arrays_sha256": (dict(meta=drop_key("arrays_sha256")), "arrays_sha256"),
    "meta without chunks": (dict(meta=drop_key("chunks")), "'chunks'"),
    "meta columns not a list": (dict(meta=set_key("columns", 5)), "indexes 5"),
    "meta chunk record garbage": (dict(meta=set_key("chunks", [None])), "chunk record"),
    "meta of the previous format": (
        dict(meta=set_key("format", "dpfexplore-lookup-index/1")),
        "format",
    ),
}


@pytest.mark.parametrize("tamper", list(TAMPERS))
def test_a_tampered_index_is_rebuilt_and_the_lookup_stays_true(inverted, tmp_path, tamper):
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    _, origin = open_index(path)
    assert origin.saved
    edit, why = TAMPERS[tamper]
    rewrite(origin.path, **edit)
    result = lookup(path, TARGET, k=3)
    assert best_of(result) == nearest(path, TARGET)
    assert result.index_origin.action == "rebuilt" and result.index_origin.saved
    note = next(n for n in result.notes if n.startswith("lookup index rebuilt: "))
    assert why in note and "\n" not in note
    assert load_index(path).verified  # the rebuilt file passes every check


@pytest.mark.parametrize("damage", ["truncated", "flip-header", "flip-middle", "flip-end"])
def test_a_damaged_index_file_is_rebuilt_not_a_traceback(inverted, tmp_path, damage):
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    _, origin = open_index(path)
    data = bytearray(origin.path.read_bytes())
    if damage == "truncated":
        data = data[: len(data) // 2]
    else:
        # the zip signature, the array data, the end-of-central-directory signature
        at = {"flip-header": 0, "flip-middle": len(data) // 2, "flip-end": len(data) - 22}[damage]
        data[at] ^= 0x10
    origin.path.write_bytes(bytes(data))
    result = lookup(path, TARGET, k=3)
    assert best_of(result) == nearest(path, TARGET)
    assert result.index_origin.action == "rebuilt"
    assert any(n.startswith("lookup index rebuilt: it") for n in result.notes)
    load_index(path)


def test_a_damaged_index_through_the_cli_is_one_note(inverted, tmp_path, capsys):
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    _, origin = open_index(path)
    origin.path.write_bytes(origin.path.read_bytes()[:100])
    assert main(["lookup", str(path), "--target", "30,20", "--k", "2"]) == 0
    captured = capsys.readouterr()
    assert "note: lookup index rebuilt: it is unreadable (BadZipFile" in captured.out
    assert "Traceback" not in captured.err
    # with --no-rebuild the damaged file is refused in one line
    origin.path.write_bytes(origin.path.read_bytes()[:100])
    assert main(["lookup", str(path), "--target", "30,20", "--no-rebuild"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "unreadable" in err


def test_rows_that_do_not_match_the_dataset_rebuild_the_index(inverted, tmp_path):
    # A forger who edits where rows live and recomputes the checksum passes the load checks;
    # the rows read back from the chunks then disagree with the index, which is rebuilt.
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    index, origin = open_index(path)
    truth = nearest(path, TARGET)
    _, rows = index.query(TARGET, 3)

    def shift(content):
        content["chunk_row"][rows] = (content["chunk_row"][rows] + 1) % 10

    rewrite(origin.path, arrays=shift, rehash=True)
    load_index(path)  # consistent on its own
    result = lookup(path, TARGET, k=3)
    assert best_of(result) == truth
    assert any("rebuilt" in n and "do not match the dataset" in n for n in result.notes)


def test_a_forged_index_cannot_change_reported_values(inverted, tmp_path):
    # With its checksum recomputed, a row moved onto the target is loaded; it becomes a
    # candidate, but its reported values and distance are the dataset's and the model's.
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    _, origin = open_index(path)
    moved = {}

    def forge(content):
        row = far_row(content)
        moved["id"] = int(content["design_id"][row])
        content["points"][row] = TARGET

    rewrite(origin.path, arrays=forge, rehash=True)
    result = lookup(path, TARGET, k=3)
    assert result.index_origin.action == "loaded"
    assert best_of(result) == nearest(path, TARGET)
    forged = next(c for c in result.candidates if c.design_id == moved["id"])
    frame = ok_rows(path)
    row = frame[frame["design_id"] == moved["id"]].iloc[0]
    np.testing.assert_array_equal(forged.source_values, [row.tip_x, row.tip_y])
    assert forged.source_distance > 10 and forged.error > 10


def damage_values(chunk, target):
    """Rewrite a chunk with its first ok row's tip moved onto ``target`` (readable, unverified)."""
    table = pq.read_table(chunk)
    frame = table.to_pandas()
    first = int(np.flatnonzero(frame["status_label"] == "ok")[0])
    for name, value in zip(TIP, target, strict=True):
        values = frame[name].to_numpy().copy()
        values[first] = value
        table = table.set_column(table.column_names.index(name), name, pa.array(values))
    pq.write_table(table, chunk, compression="zstd")
    return int(frame["design_id"][first])


def test_no_verify_then_resume_gives_the_true_nearest(inverted, tmp_path):
    spec, source = inverted
    path = fresh(source, tmp_path / "data")
    truth = nearest(path, TARGET)
    record = sorted(store.read_manifest(path).chunks.values(), key=lambda r: r.path)[3]
    damaged = damage_values(path / record.path, TARGET)
    assert damaged != truth[0]
    with pytest.raises(store.StoreError, match="changed after it was committed"):
        lookup(path, TARGET, k=1)
    # unverified: the damaged row is what the index sees, but the index is not saved
    result = lookup(path, TARGET, k=1, verify=False)
    assert result.best.design_id == damaged
    assert not result.index_origin.saved and not result.index_origin.verified
    assert any("not saved" in n and "--no-verify" in n for n in result.notes)
    assert not list(path.glob("_lookup*")) and not list(path.glob(".*.tmp"))
    # `sweep --resume` recomputes the damaged chunk; the verified lookup is right again
    run_sweep(spec, path, resume=True)
    result = lookup(path, TARGET, k=1)
    assert best_of(result) == truth
    assert result.index_origin.action == "built" and result.index_origin.saved


def test_an_unverified_index_is_never_saved(inverted, tmp_path):
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    index, origin = open_index(path, verify=False)
    assert not index.verified and not origin.saved and origin.reason.startswith("not saved")
    assert not index_path(path, TIP).exists()
    from dpfexplore.lookup.store import save_index

    with pytest.raises(ValueError, match="not built from verified"):
        save_index(index)
    # a saved verified index is loaded, not replaced, by an unverified lookup
    _, origin = open_index(path)
    before = origin.path.read_bytes()
    assert lookup(path, TARGET, k=1, verify=False).index_origin.action == "loaded"
    assert origin.path.read_bytes() == before


def test_saved_arrays_are_checksummed_in_a_fixed_order(inverted, tmp_path):
    _, source = inverted
    path = fresh(source, tmp_path / "data")
    _, origin = open_index(path)
    with np.load(origin.path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        content = {name: data[name] for name, _, _, _ in ARRAYS}
    assert meta["format"] == "dpfexplore-lookup-index/2"
    assert meta["arrays_sha256"] == arrays_checksum(content)
    manifest = store.read_manifest(path)
    assert [c["path"] for c in meta["chunks"]] == sorted(manifest.chunks, key=lambda p: p)
    for chunk in meta["chunks"]:
        assert chunk["sha256"] == manifest.chunks[chunk["path"]].sha256
        assert chunk["bytes"] == manifest.chunks[chunk["path"]].bytes


# ----------------------------------------------------------------------------- provenance


def test_provenance_of_resolved_and_reread_columns(dynamic, tmp_path, capsys):
    path = fresh(dynamic, tmp_path / "data")
    columns = ("tip_x", "tip_y", "snap_through_2")
    frame = ok_rows(path)
    frame = frame[np.isfinite(frame["snap_through_2"])]
    row = frame.iloc[5]
    target = (row.tip_x + 0.5, row.tip_y - 0.5, row.snap_through_2 * 1.05)
    _, origin = open_index(path, columns)
    # the index's copy of the re-read column is edited (checksum recomputed): never reported
    rewrite(
        origin.path, arrays=lambda c: c["points"].__setitem__((slice(None), 2), 0.0), rehash=True
    )
    result = lookup(path, target, columns=columns, k=3)
    assert result.index_origin.action == "loaded"
    assert result.provenance == {
        "tip_x": "re-solved",
        "tip_y": "re-solved",
        "stiffness": "re-solved",
        "snap_through_2": "re-read",
    }
    for c in result.candidates:
        assert c.provenance == ("re-solved", "re-solved", "re-read")
        data = frame[(frame["design_id"] == c.design_id) & (frame["requested"] == int(c.state, 2))]
        assert c.values[2] == data["snap_through_2"].iloc[0] != 0.0  # the dataset's, not 0
        np.testing.assert_array_equal(c.values[:2], c.tip)  # the solve's
    assert VERIFIED_NOTE not in result.notes
    note = next(n for n in result.notes if "re-read" in n)
    assert "snap_through_2 was re-read" in note and "SHA-256" in note
    assert not any("every reported design was re-solved" in n for n in result.notes)
    record = result.to_dict()
    assert record["provenance"]["snap_through_2"] == "re-read"
    assert record["candidates"][0]["provenance"] == {
        "tip": "re-solved",
        "stiffness": "re-solved",
        "tip_x": "re-solved",
        "tip_y": "re-solved",
        "snap_through_2": "re-read",
    }
    # unverified reads are said so
    unverified = lookup(path, target, columns=columns, k=2, verify=False)
    assert unverified.provenance["snap_through_2"] == "re-read-unverified"
    assert any("without a SHA-256 check" in n for n in unverified.notes)
    # the CLI says it per column, in the table and in JSON
    argv = ["lookup", str(path), "--columns", "reset_time_3", "--target", "1.0", "--k", "2"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    sources = out.splitlines()[3].split()
    assert sources == ["re-solved", "re-solved", "re-solved", "re-read", "re-read"]
    assert "reset_time_3 was re-read" in out and "every reported design was re-solved" not in out
    assert main([*argv, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["provenance"]["reset_time_3"] == "re-read"
    reread = ok_rows(path).set_index(["design_id", "requested"])["reset_time_3"]
    for c in record["candidates"]:
        key = (c["source"]["design_id"], int(c["state"], 2))
        assert c["values"]["reset_time_3"] == reread[key]


def test_tip_lookups_keep_the_resolved_note(inverted, capsys):
    _, path = inverted
    result = lookup(path, TARGET, k=2)
    assert set(result.provenance.values()) == {"re-solved"}
    assert VERIFIED_NOTE in result.notes


# ----------------------------------------------------------------------------- duplicates


def test_a_design_is_reported_once(tmp_path, capsys):
    # A far target: refinements from different rows end on the same corner of the box.
    path = tmp_path / "small"
    run_sweep(make_job(**{"job.name": "s", "job.samples_per_n": 6, "space.n_units": [3]}), path)
    result = lookup(path, (60.0, -20.0), k=10, refine=True)
    keys = [(c.design_id, c.state) for c in result.candidates]
    assert len(keys) == len(set(keys))
    for i, a in enumerate(result.candidates):
        for b in result.candidates[i + 1 :]:
            same = a.design.to_dict() == b.design.to_dict()
            assert not (same and a.state == b.state)
    merged = [i for c in result.candidates for i in c.also_from]
    assert merged and len(result.candidates) + len(merged) == len(ok_rows(path))
    assert any("merged" in n for n in result.notes)
    # the same row twice (a repeat of a candidate) is merged as well
    again, count = _merge_duplicates([result.best, result.best])
    assert count == 1 and again[0].also_from == (*result.best.also_from, result.best.design_id)
