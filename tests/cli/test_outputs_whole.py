"""A figure or table a command writes where the user asked is whole or absent, never part.

Every ``--plot``, ``--out`` table and ``--csv`` goes through ``save_figure`` / ``save_table``
(``cli/support/output.py``): written aside, renamed into place. A full disk (every fsync of a
file fails, as ``test_toml_written.py`` simulates it) leaves the previous file as it was, or no
file, and the command says so in one line.
"""

from __future__ import annotations

import errno
import os

import pandas as pd
import pytest
from matplotlib.figure import Figure

from dpfexplore.cli import main
from dpfexplore.cli.support.output import save_figure, save_table
from dpfexplore.examples import example_path


def _full_disk(monkeypatch):
    def fsync(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", fsync)


@pytest.mark.parametrize("name", ["t.csv", "t.parquet"])
def test_a_table_is_written_whole_and_reads_back(tmp_path, name):
    frame = pd.DataFrame({"a": [1.5, 2.5], "b": ["x", "y"]})
    save_table(frame, tmp_path / name)
    read = pd.read_csv if name.endswith(".csv") else pd.read_parquet
    pd.testing.assert_frame_equal(read(tmp_path / name), frame)
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary file left


@pytest.mark.parametrize("name", ["t.csv", "t.parquet", "f.png", "f.svg"])
def test_a_full_disk_leaves_the_previous_file_and_names_the_target(tmp_path, monkeypatch, name):
    path = tmp_path / name
    path.write_bytes(b"previous")
    _full_disk(monkeypatch)
    with pytest.raises(OSError) as failed:
        if name.startswith("t."):
            save_table(pd.DataFrame({"a": [1.0]}), path)
        else:
            save_figure(Figure(), path)
    assert failed.value.errno == errno.ENOSPC and failed.value.filename == str(path)
    assert path.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_states_plot_on_a_full_disk_is_one_line_and_keeps_the_previous_figure(
    tmp_path, capsys, monkeypatch
):
    plot = tmp_path / "states.png"
    argv = ["states", str(example_path("pickplace")), "--sequential", "--plot", str(plot)]
    assert main(argv) == 0
    drawn = plot.read_bytes()
    assert drawn.startswith(b"\x89PNG")
    capsys.readouterr()
    _full_disk(monkeypatch)
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"cannot write {plot}" in err, err
    assert plot.read_bytes() == drawn
    assert [p.name for p in tmp_path.iterdir()] == ["states.png"]
