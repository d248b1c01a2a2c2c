"""A saved surrogate's checksum proves integrity, its identity proves which model it is: a
models file swapped for another surrogate's (checksum and manifest updated) is refused in one
line naming the file and what differs; random mutations of a saved surrogate's files are refused
in one line or predict as the unmutated one."""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs
from sweep_helpers import make_job

from dpfexplore.cli import main
from dpfexplore.io.result_dirs import RESULT_MARKER
from dpfexplore.surrogates import store
from dpfexplore.surrogates.data import load_training_data
from dpfexplore.surrogates.fit import fit_surrogates
from dpfexplore.sweep.driver import run_sweep

OUTPUTS = ("tip_x", "tip_y", "stiffness")
QUICK = {"classifier": {"max_iter": 10}}


def _fit(dataset, outputs, folder):
    data = load_training_data(dataset, outputs)
    fitted = fit_surrogates(
        data, kinds=["knn"], classifier_kind="gbt", params=QUICK, timing=False, progress=None
    )
    return store.save_surrogates(fitted, folder), data


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """Three surrogates: A, B (A's data, outputs in another order), C (another dataset)."""
    root = tmp_path_factory.mktemp("identity")
    first, second = root / "sweep", root / "sweep-other"
    run_sweep(make_job(**{"job.samples_per_n": 20, "compute.states": "sequential"}), first)
    run_sweep(
        make_job(**{"job.samples_per_n": 20, "compute.states": "sequential", "job.seed": 8}),
        second,
    )
    a, data = _fit(first, OUTPUTS, root / "a")
    b, _ = _fit(first, ("stiffness", "tip_x", "tip_y"), root / "b")
    c, _ = _fit(second, OUTPUTS, root / "c")
    return {"a": a, "b": b, "c": c, "rows": data.frame[data.ok].head(5)}


def _swap(saved, source, target, *, manifest: bool):
    """``source``'s surrogate with ``target``'s models file, its checksum updated everywhere."""
    shutil.copy(saved[target] / store.MODELS, saved[source] / store.MODELS)
    _restamp(saved[source], manifest=manifest)
    return saved[source]


def _restamp(folder, *, manifest: bool) -> None:
    data = (folder / store.MODELS).read_bytes()
    meta = json.loads((folder / store.META).read_text())
    meta["models_sha256"] = hashlib.sha256(data).hexdigest()
    (folder / store.META).write_text(json.dumps(meta))
    marker = folder / RESULT_MARKER
    if not manifest:
        marker.unlink(missing_ok=True)
        return
    record = json.loads(marker.read_text())
    for name in (store.MODELS, store.META):
        content = (folder / name).read_bytes()
        record["files"][name] = {
            "bytes": len(content),
            "sha256": hashlib.sha256(content).hexdigest(),
        }
    marker.write_text(json.dumps(record))


@pytest.fixture
def copies(saved, tmp_path):
    return {
        key: shutil.copytree(saved[key], tmp_path / key) if key != "rows" else saved[key]
        for key in saved
    }


@pytest.mark.parametrize("manifest", [True, False], ids=["manifest-updated", "no-manifest"])
def test_a_swapped_models_file_with_its_checksum_updated_is_refused(copies, manifest, capsys):
    a = _swap(copies, "a", "b", manifest=manifest)
    with pytest.raises(store.SurrogateLoadError) as info:
        store.load_surrogates(a)
    message = str(info.value)
    assert "\n" not in message and str(a / store.MODELS) in message
    assert "another surrogate's models" in message and "outputs" in message
    assert (
        '["stiffness", "tip_x", "tip_y"]' in message
        and '["tip_x", "tip_y", "stiffness"]' in message
    )
    # through the command: one line, exit 2, nothing predicted
    designs = a.parent / "designs.parquet"
    copies["rows"].to_parquet(designs)
    assert main(["surrogate", "predict", str(a), str(designs)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1


def test_a_models_file_of_another_dataset_is_refused(copies):
    a = _swap(copies, "a", "c", manifest=True)
    with pytest.raises(
        store.SurrogateLoadError, match=r"recorded dataset\.job_fingerprint"
    ) as info:
        store.load_surrogates(a)
    assert str(a / store.MODELS) in str(info.value)


def test_a_forged_identity_record_is_caught_by_the_estimators(copies):
    import skops.io as sio

    a = copies["a"]
    payload = sio.load(copies["b"] / store.MODELS, trusted=list(store.TRUSTED_TYPES))
    payload["identity"] = json.loads((a / store.META).read_text())["identity"]  # a's record
    (a / store.MODELS).write_bytes(sio.dumps(payload))
    _restamp(a, manifest=True)
    with pytest.raises(store.SurrogateLoadError, match=r"regressor:knn\.outputs") as info:
        store.load_surrogates(a)
    assert str(a / store.MODELS) in str(info.value)
    payload["identity"] = np.arange(3)  # a record of another type altogether
    (a / store.MODELS).write_bytes(sio.dumps(payload))
    _restamp(a, manifest=True)
    with pytest.raises(store.SurrogateLoadError, match="another surrogate's models") as info:
        store.load_surrogates(a)
    assert "\n" not in str(info.value)


def test_the_unswapped_surrogates_load_and_say_what_they_predict(saved):
    rows = saved["rows"]
    a, b = store.load_surrogates(saved["a"]), store.load_surrogates(saved["b"])
    assert a.outputs == OUTPUTS and b.outputs == ("stiffness", "tip_x", "tip_y")
    np.testing.assert_array_equal(
        a.predict(rows)[list(OUTPUTS)].to_numpy(), b.predict(rows)[list(OUTPUTS)].to_numpy()
    )
    meta = json.loads((saved["a"] / store.META).read_text())
    knn = meta["identity"]["estimators"]["regressor:knn"]
    assert knn["outputs"] == list(OUTPUTS) and knn["n_outputs"] == 3
    assert (
        meta["identity"]["dataset"]["chunks_sha256"]
        == meta["dataset"]["fingerprint"]["chunks_sha256"]
    )
    assert all(len(names) > 0 for names in knn["features"].values())


def test_special_files_in_a_surrogate_are_refused_in_one_line(copies, capsys):
    a = copies["a"]
    fifo = a.parent / "designs.parquet"
    os.mkfifo(fifo)  # a named pipe as the designs to predict: refused, never waited on
    assert main(["surrogate", "predict", str(a), str(fifo)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(fifo) in err[0] and "a FIFO" in err[0]
    (a / RESULT_MARKER).unlink()
    (a / store.META).unlink()
    (a / store.META).symlink_to("/dev/zero")
    with pytest.raises(store.SurrogateLoadError, match="not a regular file") as info:
        store.load_surrogates(a)
    assert str(a / store.META) in str(info.value)


# ----------------------------------------------------------------------------- property

REPLACEMENTS = (None, "x", 3, [], {}, float("nan"), 1e308, -1)


@settings(max_examples=30)
@given(
    target=hs.sampled_from(["meta", "models"]),
    pick=hs.integers(0, 10**6),
    replacement=hs.integers(0, len(REPLACEMENTS)),
    restamp=hs.booleans(),
    bit=hs.integers(0, 7),
)
def test_mutations_are_refused_in_one_line_or_predict_the_same(
    saved, tmp_path_factory, target, pick, replacement, restamp, bit
):
    folder = shutil.copytree(saved["a"], tmp_path_factory.mktemp("fuzz") / "a")
    if target == "models":  # a flipped byte; with restamp, the checksum updated to match
        raw = bytearray((folder / store.MODELS).read_bytes())
        raw[pick % len(raw)] ^= 1 << bit
        (folder / store.MODELS).write_bytes(bytes(raw))
    else:  # an entry of surrogate.json deleted or replaced
        meta = json.loads((folder / store.META).read_text())
        paths = _paths(meta)
        *parents, last = paths[pick % len(paths)]
        entry = meta
        for key in parents:
            entry = entry[key]
        if replacement == len(REPLACEMENTS):
            entry.pop(last)
        else:
            entry[last] = REPLACEMENTS[replacement]
        (folder / store.META).write_text(json.dumps(meta))
    if restamp:
        _restamp(folder, manifest=True)
    try:
        loaded = store.load_surrogates(folder)
    except store.SurrogateLoadError as exc:
        assert "\n" not in str(exc) and str(folder) in str(exc)
        return
    rows = saved["rows"]
    expected = store.load_surrogates(saved["a"]).predict(rows)
    assert loaded.predict(rows).equals(expected)


def _paths(data, prefix=()):
    items = data.items() if isinstance(data, dict) else enumerate(data)
    out = []
    for key, value in items:
        out.append((*prefix, key))
        if isinstance(value, (dict, list)) and value:
            out += _paths(value, (*prefix, key))
    return out
