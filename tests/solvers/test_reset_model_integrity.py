"""A reset-model file is checked whole before the tree kernel sees it: checksum, format version,
provenance, every index, every tree's shape and every value; a damaged or hostile file is one
line naming it (never a crash, a hang or exit 0), and random mutations of a small valid file are
refused or give the unmutated model."""

from __future__ import annotations

import copy
import json
import os

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as hs

from dpfexplore.cli import main
from dpfexplore.solvers.dynamics.reset_model import (
    DEFAULT_MODEL_PATH,
    FEATURES,
    FORMAT_VERSION,
    LOG_LIMIT,
    ResetModel,
    TreeEnsemble,
    canonical_sha256,
    load_reset_model,
)

PROBE = np.random.default_rng(5).normal(size=(7, len(FEATURES))) * 3.0


def _stamped(data: dict) -> dict:
    body = {k: v for k, v in data.items() if k != "sha256"}
    return {**body, "sha256": canonical_sha256(body)}


def _first_trees(trees: TreeEnsemble, count: int) -> TreeEnsemble:
    end = int(trees.roots[count])
    return TreeEnsemble(
        trees.feature[:end],
        trees.threshold[:end],
        trees.left[:end],
        trees.right[:end],
        trees.value[:end],
        trees.roots[:count],
        trees.bias,
        trees.n_features,
    )


@pytest.fixture(scope="module")
def small() -> dict:
    """A valid small model file's contents: two trees of each ensemble of the packaged model."""
    packaged = load_reset_model()
    model = ResetModel(
        **{
            **{k: getattr(packaged, k) for k in packaged.__dataclass_fields__},
            "correction": _first_trees(packaged.correction, 2),
            "scale": _first_trees(packaged.scale, 2),
            "info": {"trained": "test"},
        }
    )
    return model.to_dict()


def _refused_in_one_line(capsys, path) -> str:
    assert main(["reset-model", "report", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err
    return err


def test_packaged_model_has_checksum_version_provenance_and_reads_back_exactly(tmp_path):
    text = DEFAULT_MODEL_PATH.read_text()
    data = json.loads(text)
    assert data["format_version"] == FORMAT_VERSION == 2
    assert data["sha256"] == canonical_sha256({k: v for k, v in data.items() if k != "sha256"})
    assert data["provenance"]["created"] == "2026-12-01 18:03:56 UTC"
    assert "upgraded" in data["provenance"] and data["correction"]["n_features"] == 21
    model = load_reset_model()
    # the file is what the model writes: saving it again gives the same bytes
    assert model.save(tmp_path / "again.json").read_text() == text
    # the numbers of the trained model (format 1) are kept bit for bit
    assert model.correction.bias == -5.6937517707334576e-05
    assert model.scale.bias == 0.012412388662513015
    assert model.correction.roots.size == 21 and model.scale.roots.size == 59
    assert model.correction.output_range == tuple(data["correction"]["range"])


def _mutate(data: dict, edit) -> dict:
    data = copy.deepcopy(data)
    edit(data)
    return _stamped(data)


def _first_internal(trees: dict) -> int:
    return next(i for i, child in enumerate(trees["left"]) if child >= 0 and i > 0)


def _first_leaf(trees: dict) -> int:
    return next(i for i, child in enumerate(trees["left"]) if child < 0)


CASES = {
    "feature out of range": (
        lambda d: d["correction"]["feature"].__setitem__(0, 10**6),
        "feature[0] = 1000000: outside the 21 input features",
    ),
    "negative feature": (
        lambda d: d["scale"]["feature"].__setitem__(0, -3),
        "feature[0] = -3",
    ),
    "child out of range": (
        lambda d: d["correction"]["right"].__setitem__(0, 10**9),
        "right[0] = 1000000000: outside the nodes",
    ),
    "cycle": (
        lambda d: d["correction"]["left"].__setitem__(_first_internal(d["correction"]), 0),
        "outside the nodes",
    ),
    "node reached twice": (
        lambda d: d["correction"]["right"].__setitem__(0, d["correction"]["left"][0]),
        "is the child of 2 nodes",
    ),
    "leaf with one child": (
        lambda d: d["scale"]["right"].__setitem__(
            _first_leaf(d["scale"]), _first_leaf(d["scale"]) + 1
        ),
        "a node has two children or none",
    ),
    "root out of order": (
        lambda d: d["scale"]["roots"].__setitem__(1, 0),
        "roots: need 0 first",
    ),
    "bias of 1e308": (
        lambda d: d["correction"].__setitem__("bias", 1e308),
        "outside the recorded range",
    ),
    "bias of 1e308 and its range": (
        lambda d: d["correction"].update(bias=1e308, range=[-1e308, 1e308]),
        f"within ±{LOG_LIMIT:g}",
    ),
    "huge integer leaf": (
        lambda d: d["scale"]["value"].__setitem__(_first_leaf(d["scale"]), 10**400),
        "need a finite number",
    ),
    "float index": (
        lambda d: d["correction"]["left"].__setitem__(0, 1.0),
        "left[0] = 1.0: need an integer",
    ),
    "negative coverage": (lambda d: d.__setitem__("coverage", -0.9), "coverage = -0.9"),
    "domain without bounds": (
        lambda d: d["domain"].__setitem__("H", [5.0, 2.0]),
        "domain.H = [5.0, 2.0]",
    ),
    "scene backwards": (lambda d: d["scene"].__setitem__("tau", [5, 1, 0, 0]), "scene: tau"),
    "no provenance": (lambda d: d.pop("provenance"), "provenance: need"),
    "width of the trees": (
        lambda d: d["scale"].__setitem__("n_features", 22),
        "scale.n_features = 22: need 21",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_hostile_tree_or_value_is_refused_in_one_line(small, tmp_path, capsys, case):
    edit, message = CASES[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_mutate(small, edit)))  # re-stamped: the checks, not the checksum
    assert message in _refused_in_one_line(capsys, path)
    with pytest.raises(ValueError, match="reset model"):
        load_reset_model(path)


def test_a_nan_leaf_an_edited_file_and_an_old_file_are_refused(small, tmp_path, capsys):
    leaf = _first_leaf(small["scale"])
    nan = tmp_path / "nan.json"
    data = copy.deepcopy(small)
    data["scale"]["value"][leaf] = float("nan")
    nan.write_text(json.dumps(data))
    assert "NaN is not a JSON number" in _refused_in_one_line(capsys, nan)
    edited = tmp_path / "edited.json"
    data = copy.deepcopy(small)
    data["scale"]["threshold"][0] += 0.125  # a valid model, but not the one stamped
    edited.write_text(json.dumps(data))
    assert "sha256 differs from the contents" in _refused_in_one_line(capsys, edited)
    old = tmp_path / "old.json"
    data = {k: v for k, v in small.items() if k not in ("sha256", "provenance")}
    old.write_text(json.dumps({**data, "format_version": 1}))
    assert "reset-model upgrade" in _refused_in_one_line(capsys, old)
    # the upgrade checks the old file and keeps its numbers
    new = tmp_path / "new.json"
    assert main(["reset-model", "upgrade", str(old), "--out", str(new)]) == 0
    capsys.readouterr()
    again = load_reset_model(new)
    np.testing.assert_array_equal(again.scale.value, small["scale"]["value"])
    assert again.provenance["created"] == "test" or "upgraded" in again.provenance


def test_special_files_and_truncation_are_one_line(small, tmp_path, capsys):
    folder = tmp_path / "folder.json"
    folder.mkdir()
    assert "is a directory" in _refused_in_one_line(capsys, folder)
    assert "not a regular file" in _refused_in_one_line(capsys, "/dev/zero")
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    assert "not a regular file (a FIFO)" in _refused_in_one_line(capsys, fifo)
    truncated = tmp_path / "truncated.json"
    truncated.write_text(json.dumps(small)[:1000])
    assert "not JSON" in _refused_in_one_line(capsys, truncated)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    assert "nested too deeply" in _refused_in_one_line(capsys, deep)
    assert "no such file" in _refused_in_one_line(capsys, tmp_path / "missing.json")


def test_simulate_refuses_a_cyclic_model_before_the_kernel(small, tmp_path, capsys):
    path = tmp_path / "cycle.json"
    cyclic = _mutate(small, CASES["cycle"][0])
    path.write_text(json.dumps(cyclic))
    argv = ["simulate", "pickplace", "--method", "fast", "--reset-model", str(path)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "correction: left[" in err[0]


def test_tree_arrays_are_checked_in_python_and_copied():
    packaged = load_reset_model().correction
    left = packaged.left.copy()
    left[0] = 0  # the root its own child: a loop the kernel would never leave
    with pytest.raises(ValueError, match=r"left\[0\] = 0"):
        TreeEnsemble(
            *(getattr(packaged, k) for k in ("feature", "threshold")),
            left,
            packaged.right,
            packaged.value,
            packaged.roots,
            packaged.bias,
            21,
        )
    feature = packaged.feature.copy()
    trees = TreeEnsemble(
        feature,
        packaged.threshold,
        packaged.left,
        packaged.right,
        packaged.value,
        packaged.roots,
        packaged.bias,
        21,
    )
    feature[:] = 10**6  # the caller's array, not the ensemble's
    np.testing.assert_array_equal(trees.predict(PROBE), packaged.predict(PROBE))
    with pytest.raises(ValueError, match=r"need \(n_rows, 21\)"):
        trees.predict(PROBE[:, :5])


# ----------------------------------------------------------------------------- property

_PATHS_SKIPPED = ("info",)


def _leaves(data, prefix=()):
    """Paths of every value in a JSON document (lists' items and tables' entries)."""
    if isinstance(data, dict):
        items = data.items()
    elif isinstance(data, list):
        items = enumerate(data)
    else:
        return [prefix]
    out = [prefix] if prefix else []
    for key, value in items:
        out += _leaves(value, (*prefix, key))
    return out


REPLACEMENTS = (None, "x", True, [], {}, -1, 0, 1e308, -1e308, 10**400, 2**63, 0.5, float("nan"))


@settings(max_examples=80)
@given(
    pick=hs.integers(0, 10**6),
    action=hs.sampled_from(["delete", *range(len(REPLACEMENTS)), "flip"]),
    restamp=hs.booleans(),
    flip=hs.integers(0, 10**6),
    bit=hs.integers(0, 7),
)
@example(pick=0, action="flip", restamp=False, flip=100, bit=0)
def test_mutations_are_refused_in_one_line_or_change_nothing(
    small, tmp_path_factory, pick, action, restamp, flip, bit
):
    path = tmp_path_factory.mktemp("fuzz") / "model.json"
    if action == "flip":
        raw = bytearray(json.dumps(small).encode())
        raw[flip % len(raw)] ^= 1 << bit
        path.write_bytes(bytes(raw))
    else:
        data = copy.deepcopy(small)
        paths = [p for p in _leaves(data) if p[0] not in _PATHS_SKIPPED and p != ("sha256",)]
        *parents, last = paths[pick % len(paths)]
        target = data
        for key in parents:
            target = target[key]
        if action == "delete":
            target.pop(last)
        else:
            target[last] = copy.deepcopy(REPLACEMENTS[action])
        if restamp:
            try:
                data = _stamped(data)
            except ValueError:  # NaN or 10**400 has no canonical JSON: written unstamped
                pass
        path.write_text(json.dumps(data))
    try:
        model = load_reset_model(path)
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message and str(path) in message
        return
    if not restamp or action == "flip":
        assert model.to_dict() == small  # the checksum lets nothing else through
    for trees in (model.correction, model.scale):
        out = trees.predict(PROBE)
        low, high = trees.output_range
        assert np.all(np.isfinite(out)) and np.all((out >= low) & (out <= high))
        assert -LOG_LIMIT <= low <= high <= LOG_LIMIT
