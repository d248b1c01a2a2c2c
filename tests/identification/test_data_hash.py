"""Identification's ``data_sha256`` hashes everything a fit reads of its table; duplicate rows,
special files and non-finite options are refused in one line; random mutations of a small curve
table are refused in one line naming the file, or read with a hash that says whether anything a
fit reads changed."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from dpfexplore.cli import main
from dpfexplore.identification.curves import COLUMNS, CurveError, read_curves
from dpfexplore.identification.features import read_feature_curves
from dpfexplore.identification.identify import data_sha256, identify
from dpfexplore.identification.states import read_states_curves

READERS = (read_curves, read_feature_curves, read_states_curves)


def _folded_table(n_curves: int = 2) -> pd.DataFrame:
    """Curves traced as two overlapping branches (a folded path), with energies and forces."""
    frames = []
    for k in range(n_curves):
        x = np.linspace(0.0, 4.0, 41)
        energy = (1.0 + 0.1 * k) * x**2 * (x - 3.0) ** 2
        force = np.gradient(energy, x)
        for branch, keep, lift in (("up", x <= 3.0, 0.0), ("inverted", x >= 2.0, 0.3)):
            frames.append(
                pd.DataFrame(
                    {
                        "curve": f"c{k}",
                        "H": 4.0 + 0.1 * k,
                        "t": 0.8,
                        "r_b": 5.0,
                        "E": 26.0,
                        "nu": 0.35,
                        "displacement": x[keep],
                        "energy": energy[keep] + lift,
                        "force": force[keep],
                        "branch": branch,
                    }
                )
            )
    return pd.concat(frames, ignore_index=True)


def _hash(path, reader=read_curves) -> str:
    return data_sha256(reader(path))


@pytest.mark.parametrize("reader", READERS, ids=lambda r: r.__name__)
def test_force_times_1_5_changes_the_hash(tmp_path, reader):
    table = _folded_table()
    table.to_csv(tmp_path / "a.csv", index=False)
    table.assign(force=table["force"] * 1.5).to_csv(tmp_path / "b.csv", index=False)
    first, second = _hash(tmp_path / "a.csv", reader), _hash(tmp_path / "b.csv", reader)
    assert first != second
    # the same rows read again (or from Parquet) hash the same
    table.to_parquet(tmp_path / "a.parquet", index=False)
    assert _hash(tmp_path / "a.parquet", reader) == first


def test_every_column_a_fit_reads_is_in_the_hash(tmp_path):
    table = _folded_table()
    table.to_csv(tmp_path / "base.csv", index=False)
    base = _hash(tmp_path / "base.csv")
    seen = {base}
    for column in COLUMNS:
        if column not in table or column == "curve":
            continue
        changed = table.copy()
        if column == "branch":
            changed.loc[changed["branch"] == "up", "branch"] = "first"
        else:
            changed[column] = changed[column] * (1 + 1e-12) + (1e-12 if column != "nu" else 0)
        changed.to_csv(tmp_path / f"{column}.csv", index=False)
        seen.add(_hash(tmp_path / f"{column}.csv"))
    assert len(seen) == 1 + sum(c in table and c != "curve" for c in COLUMNS)
    # a column no fit reads does not change it
    table.assign(note="x").to_csv(tmp_path / "note.csv", index=False)
    assert _hash(tmp_path / "note.csv") == base


def test_duplicate_rows_are_refused_in_one_line(tmp_path, capsys):
    table = _folded_table()
    doubled = pd.concat([table, table], ignore_index=True)
    path = tmp_path / "doubled.csv"
    doubled.to_csv(path, index=False)
    for reader in READERS:
        with pytest.raises(CurveError, match="repeats an earlier row") as info:
            reader(path)
        assert str(path) in str(info.value) and "\n" not in str(info.value)
    argv = ["identify", "fit", str(path), "--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}: row {len(table)} (curve 'c0') repeats" in err[0]


def test_special_files_are_refused_before_reading(tmp_path, capsys):
    folder = tmp_path / "folder.csv"
    folder.mkdir()
    fifo = tmp_path / "fifo.parquet"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.csv"
    zero.symlink_to("/dev/zero")
    cases = {folder: "is a directory", fifo: "a FIFO", zero: "not a regular file"}
    for path, says in cases.items():
        assert main(["identify", "fit", str(path), "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(path) in err[0] and says in err[0]


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "0", "-0.1"])
def test_max_rms_must_be_a_finite_positive_number(tmp_path, capsys, value):
    path = tmp_path / "curves.csv"
    _folded_table().to_csv(path, index=False)
    argv = ["identify", "fit", str(path), "--out", str(tmp_path / "out"), f"--max-rms={value}"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--max-rms" in err[0]
    with pytest.raises(ValueError, match="max_relative_rms"):
        identify([], name="x", max_relative_rms=float(value))


# ----------------------------------------------------------------------------- property

SMALL = _folded_table(1)
CELLS = ["", "nan", "inf", "-1", "1e308", "x", "0", "1e-300"]


@settings(max_examples=60)
@given(
    row=hs.integers(0, len(SMALL) - 1),
    column=hs.sampled_from(list(SMALL.columns)),
    cell=hs.sampled_from(CELLS),
    action=hs.sampled_from(["cell", "drop_column", "drop_row", "duplicate_row", "flip"]),
    flip=hs.integers(0, 10**6),
    bit=hs.integers(0, 7),
)
def test_mutated_tables_are_refused_in_one_line_or_hash_what_changed(
    tmp_path_factory, row, column, cell, action, flip, bit
):
    folder = tmp_path_factory.mktemp("table")
    original = folder / "original.csv"
    SMALL.to_csv(original, index=False)
    path = folder / "mutated.csv"
    if action == "flip":
        raw = bytearray(original.read_bytes())
        raw[flip % len(raw)] ^= 1 << bit
        path.write_bytes(bytes(raw))
    else:
        table = SMALL.astype(object)
        if action == "cell":
            table.loc[row, column] = cell
        elif action == "drop_column":
            table = table.drop(columns=column)
        elif action == "drop_row":
            table = table.drop(index=row)
        else:
            table = pd.concat([table, table.iloc[[row]]], ignore_index=True)
        table.to_csv(path, index=False)
    try:
        curves = read_states_curves(path)
    except CurveError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(f"{path}:")
        return
    for curve in curves:  # what was read is checked: finite, positive, sorted or folded
        assert np.all(np.isfinite(curve.displacement)) and curve.H > 0 and curve.E > 0
    read_back = pd.read_csv(path)
    same = [c for c in COLUMNS if c in read_back] == [c for c in COLUMNS if c in SMALL]
    same = same and read_back[[c for c in COLUMNS if c in SMALL]].astype(str).equals(
        SMALL[[c for c in COLUMNS if c in SMALL]].astype(str)
    )
    assert (data_sha256(curves) == data_sha256(read_states_curves(original))) == same
