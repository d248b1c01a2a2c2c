"""Lookup over real small sweeps: the index equals a brute-force scan of the dataset, persists
beside it, is refused when stale, reads a dataset being written through its committed chunks,
and every reported design is the dataset's (verified by re-solving)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pandas as pd
import pytest
from sweep_helpers import make_job

from dpfexplore import Design, find_state
from dpfexplore.lookup import index as lookup_index
from dpfexplore.lookup.index import StaleIndexError, build_index, mask_of
from dpfexplore.lookup.query import lookup, parse_n_units
from dpfexplore.lookup.store import index_path, load_index, open_index
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage import store
from dpfexplore.sweep.storage.datasets import dataset_info

RNG = np.random.default_rng(20261201)


def sweep(root, name, **changes):
    spec = make_job(**{"job.name": name, **changes})
    run_sweep(spec, root / name)
    return spec, root / name


@pytest.fixture(scope="module")
def sequential(tmp_path_factory):
    """N = 2, 3, 4, sequential states (several states per N), stiffness; 12 chunks."""
    root = tmp_path_factory.mktemp("lookup")
    return sweep(
        root,
        "seq",
        **{
            "job.samples_per_n": 60,
            "job.chunk_size": 15,
            "space.n_units": [2, 3, 4],
            "compute.states": "sequential",
        },
    )


def copy_dataset(source, target):
    """A copy of a sweep directory without any saved index."""
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("_lookup*"))


def ok_rows(path) -> pd.DataFrame:
    frame = store.read_results(path)
    return frame[frame["status_label"] == "ok"].reset_index(drop=True)


def brute_force(frame, target, k, columns=("tip_x", "tip_y"), scales=(1.0, 1.0)):
    """The k nearest rows by an independent pandas computation (design_id, requested, d)."""
    scaled = frame[list(columns)].to_numpy(float) / np.asarray(scales)
    d = np.sqrt(((scaled - np.asarray(target) / np.asarray(scales)) ** 2).sum(axis=1))
    order = np.argsort(d, kind="stable")[:k]
    return list(
        zip(frame["design_id"].to_numpy()[order], frame["requested"].to_numpy()[order], strict=True)
    ), d[order]


@pytest.mark.parametrize("scan_rows", [0, 16384], ids=["tree-for-filters", "scan-small-sets"])
def test_query_equals_brute_force_scan_with_every_filter(sequential, scan_rows, monkeypatch):
    # Row filters are served by the tree (asking for more neighbours until k pass) or, for
    # small filtered sets, by a scan; the threshold 0 forces the tree whenever it can serve.
    monkeypatch.setattr(lookup_index, "_SCAN_ROWS", scan_rows)
    _, path = sequential
    frame = ok_rows(path)
    index = build_index(path)
    assert len(index) == len(frame)
    n_all = frame["n_units"].to_numpy().astype(int)
    filters = {
        "none": ({}, np.ones(len(frame), bool)),
        "N 3..4": ({"n_units": (3, 4)}, n_all >= 3),
        "state 110": ({"state": "110"}, (n_all == 3) & (frame["requested"] == 6)),
        "all-inverted": ({"state": "all-inverted"}, frame["requested"] == 2**n_all - 1),
    }
    tips = frame[["tip_x", "tip_y"]].to_numpy()
    for _ in range(25):
        target = tips[RNG.integers(len(frame))] + RNG.normal(0, 3, 2)
        for kwargs, keep in filters.values():
            got_d, got_rows = index.query(target, 7, **kwargs)
            want, want_d = brute_force(frame[keep], target, 7)
            got = list(zip(index.design_id[got_rows], index.requested[got_rows], strict=True))
            assert got == want
            np.testing.assert_allclose(got_d, want_d, rtol=0, atol=1e-12)
        # a row filter (a --where expression) is exact, including very selective ones
        for share in (0.5, 0.2, 0.02):
            allowed = RNG.random(len(frame)) < share
            keys = frame.loc[allowed, ["design_id", "requested"]]
            mask = mask_of(index, {c: keys[c].to_numpy() for c in keys})
            got_d, got_rows = index.query(target, 5, mask=mask)
            want, want_d = brute_force(frame[allowed], target, 5)
            got = list(zip(index.design_id[got_rows], index.requested[got_rows], strict=True))
            assert got == want


def test_scaled_columns_equal_brute_force(sequential):
    _, path = sequential
    frame = ok_rows(path)
    columns, scales = ("tip_x", "tip_y", "stiffness"), (1.0, 1.0, 0.01)
    index = build_index(path, columns, scales)
    for _ in range(10):
        row = frame.iloc[int(RNG.integers(len(frame)))]
        target = [row.tip_x + 1.0, row.tip_y - 2.0, row.stiffness * 1.1]
        got_d, got_rows = index.query(target, 6)
        want, want_d = brute_force(frame, target, 6, columns, scales)
        assert list(zip(index.design_id[got_rows], index.requested[got_rows], strict=True)) == want
        np.testing.assert_allclose(got_d, want_d, rtol=1e-12)


def test_lookup_reports_dataset_designs_verified(sequential):
    _, path = sequential
    frame = ok_rows(path)
    target = (35.0, 20.0)
    result = lookup(path, target, k=6, state="all-inverted")
    inverted = frame[frame["requested"] == 2 ** frame["n_units"].astype(int) - 1]
    want, want_d = brute_force(inverted, target, 6)
    assert [(c.design_id, int(c.state, 2)) for c in result.candidates] == want
    for c, d in zip(result.candidates, want_d, strict=True):
        row = inverted[inverted["design_id"] == c.design_id].iloc[0]
        n = int(row.n_units)
        assert c.design.H == tuple(row[f"H_{k}"] for k in range(1, n + 1))
        assert c.design.U_sep == tuple(row[f"U_sep_{k}"] for k in range(1, n + 1))
        assert (c.design.t, c.design.t_lim, c.design.E) == (row.t, row.t_lim, row.E)
        # re-solved: an independent find_state gives the reported tip and the dataset's
        again = find_state(c.design, c.state)
        np.testing.assert_allclose(c.tip, again.tip, rtol=0, atol=1e-12)
        np.testing.assert_allclose(c.tip, [row.tip_x, row.tip_y], rtol=0, atol=1e-9)
        # the state exists, but a dataset design misses the target: labelled so, not "ok"
        assert c.status == ("ok" if d <= 1e-6 else "not_met") and c.found == c.state
        assert not c.refined
        assert c.error == pytest.approx(d, abs=1e-9)
        assert c.fitted_range
    assert result.reachable is False and result.dataset.complete
    assert any("target not met" in note and "--refine" in note for note in result.notes)
    assert any("re-solved" in note for note in result.notes)
    record = json.loads(json.dumps(result.to_dict()))
    assert record["target"] == [35.0, 20.0]
    first = record["candidates"][0]
    assert set(first["design"]) == {"H", "U_L", "U_sep", "t", "t_lim", "E", "nu", "r_b", "t_ch"}
    assert Design.from_dict(first["design"]) == result.best.design
    assert first["state"] == result.best.state and first["status"] == "not_met"


def test_index_is_saved_beside_the_dataset_and_reloaded(sequential, tmp_path):
    _, original = sequential
    path = tmp_path / "data"
    copy_dataset(original, path)
    rows_before = len(pd.read_parquet(path))
    index, origin = open_index(path)
    assert origin.action == "built" and origin.saved
    assert origin.path == index_path(path, ("tip_x", "tip_y")) and origin.path.parent == path
    # the file is not data: Parquet readers and the sweep store skip it
    assert len(pd.read_parquet(path)) == rows_before
    assert len(store.read_results(path)) == rows_before
    again, origin = open_index(path)
    assert origin.action == "loaded"
    for name in ("points", "design_id", "requested", "n_units", "file", "row"):
        np.testing.assert_array_equal(getattr(again, name), getattr(index, name))
    # no pickle in the file
    with np.load(origin.path, allow_pickle=False) as data:
        assert all(data[key].dtype != object for key in data.files)


def drop_chunks(path, keep):
    """Uncommit all but ``keep`` chunks (files stay on disk): a sweep caught mid-way."""
    manifest = store.read_manifest(path)
    manifest.chunks = {p: r for p, r in manifest.chunks.items() if keep(r)}
    manifest.complete = False
    store.write_manifest(path, manifest)
    return manifest


def test_stale_index_is_refused_and_rebuilt(sequential, tmp_path):
    spec, original = sequential
    path = tmp_path / "data"
    copy_dataset(original, path)
    drop_chunks(path, lambda r: r.index < 2)
    partial, origin = open_index(path)
    assert origin.action == "built" and not partial.complete
    # a no-op rewrite of the manifest changes no data: the index stays valid
    manifest = store.read_manifest(path)
    store.write_manifest(path, manifest)
    load_index(path)
    # the sweep goes on: every chunk committed, the saved index is stale
    run_sweep(spec, path, resume=True)
    with pytest.raises(StaleIndexError, match="stale"):
        load_index(path)
    with pytest.raises(StaleIndexError, match="stale"):
        open_index(path, rebuild=False)
    with pytest.raises(StaleIndexError, match="stale"):
        lookup(path, (30.0, 20.0), index=partial)
    with pytest.raises(StaleIndexError):
        partial.check()
    fresh, origin = open_index(path)
    assert origin.action == "rebuilt" and "stale" in origin.reason
    assert len(fresh) == len(ok_rows(path)) > len(partial)
    load_index(path)  # the rebuilt file is fresh


def test_dataset_being_written_is_read_through_committed_chunks(sequential, tmp_path):
    _, original = sequential
    path = tmp_path / "data"
    copy_dataset(original, path)
    everything = ok_rows(path)
    manifest = drop_chunks(path, lambda r: r.index == 0)
    committed = ok_rows(path)
    assert 0 < len(committed) < len(everything)
    info = dataset_info(path)
    assert not info.complete and info.designs_committed == manifest.n_designs_committed
    # target: the tip of a row that is on disk but not committed
    hidden = everything[~everything["design_id"].isin(committed["design_id"])].iloc[3]
    target = (hidden.tip_x, hidden.tip_y)
    result = lookup(path, target, k=4)
    want, _ = brute_force(committed, target, 4)
    assert [(c.design_id, int(c.state, 2)) for c in result.candidates] == want
    assert hidden.design_id not in {c.design_id for c in result.candidates}
    assert result.best.source_distance > 0
    assert not result.dataset.complete
    assert any("incomplete" in n and "committed chunks" in n for n in result.notes)


def test_dataset_of_another_model_version_is_said_so(sequential, tmp_path):
    _, original = sequential
    path = tmp_path / "data"
    copy_dataset(original, path)
    assert not any("model version" in n for n in lookup(path, (30.0, 20.0), k=1).notes)
    manifest = store.read_manifest(path)
    manifest.model_version = "dpf-lattice-0"
    store.write_manifest(path, manifest)
    notes = lookup(path, (30.0, 20.0), k=1).notes
    assert any("model version 'dpf-lattice-0'" in n and "re-solved" in n for n in notes)


def test_n_units_parsing():
    assert parse_n_units("3..5") == (3, 4, 5) and parse_n_units("2,7") == (2, 7)
    for bad in ("5..3", "x", "0", "13"):
        with pytest.raises(ValueError, match="n_units"):
            parse_n_units(bad)


def test_bad_lookups_raise_naming_the_problem(sequential, tmp_path):
    _, path = sequential
    with pytest.raises(ValueError, match="column 'tip_z'"):
        lookup(path, (1.0, 2.0), columns=("tip_x", "tip_z"))
    with pytest.raises(ValueError, match="need 2 finite values"):
        lookup(path, (1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="not numeric"):
        lookup(path, (1.0, 2.0), columns=("tip_x", "status_label"))
    with pytest.raises(ValueError, match="no indexed rows match"):
        lookup(path, (1.0, 2.0), n_units=(7,))
    with pytest.raises(ValueError, match="cannot be refined"):
        lookup(path, (1.0,), columns=("grad_norm",), refine=True)
    with pytest.raises(store.StoreError, match="no such dataset"):
        lookup(tmp_path / "nowhere", (1.0, 2.0))
