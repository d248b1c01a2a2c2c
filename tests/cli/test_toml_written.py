"""What the tool writes is what it reads back; a full disk, a hostile value or an absurd size is
one line, never a traceback.

Cases: a scene name and a dataset directory with a newline (design TOMLs stay valid TOML and
read back), a full disk (ENOSPC, simulated in-process) under ``lookup --write``, ``design
--out`` and the CLI's handler for every command, ``states`` whose every state fails,
``lookup --target 1e300,20``, a 500-term ``--where``, a sweep plan too large for memory.
"""

from __future__ import annotations

import errno
import os
import shutil
import tomllib

import pytest
from sweep_helpers import make_job

from dpfexplore.cli import main
from dpfexplore.io.toml_write import TomlWriteError, comment, write_toml
from dpfexplore.lookup.files import write_design_file
from dpfexplore.model.design import Design, load_design
from dpfexplore.sweep.chunks import MAX_CHUNKS, PlanTooLarge, check_plan
from dpfexplore.sweep.driver import run_sweep

SCENE = """[scene]
kind = "position"
name = "line\\none"
material = "cheetah-95a"
seed = 0

[variables]
n_units = {min = 2, max = 2}
H = {min = 3.0, max = 5.0}
U_L = {min = 5.5, max = 10.0}
U_sep = {min = 1.0, max = 5.0}
t = {min = 0.5, max = 1.0}
t_lim = {min = 1.0, max = 2.0}

[[targets]]
point = [25.0, 20.0]

[objective]
state = "all_inverted"
tolerance = 1e-6

[optimiser]
candidates_per_n = 4
starts_per_n = 1
max_iter = 5
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A dataset in a directory whose name holds a newline: N = 3, all units inverted."""
    path = tmp_path_factory.mktemp("written") / "data\nset"
    job = make_job(**{"job.name": "inv", "job.samples_per_n": 40, "space.n_units": [3]})
    run_sweep(job, path)
    return path


def _one_line(err: str, start: str) -> str:
    err = err.strip()
    assert err.startswith(start) and "\n" not in err, err
    return err


def _full_disk(monkeypatch):
    """Every fsync of a file fails as on a full disk (directories' fsyncs are not checked)."""

    def fsync(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", fsync)


# ----------------------------------------------------------------------------- written, read back


def test_a_design_named_with_a_newline_is_written_as_valid_toml_and_reads_back(tmp_path):
    design = Design(H=[4.0, 4.5], U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.2, name='a\nb"\x7f')
    path = write_design_file(
        tmp_path / "d.toml", design, ["line\none", "tab\there \ud800"], {"tip": [1.0, None]}
    )
    document = tomllib.loads(path.read_text())
    assert document["design"]["name"] == 'a\nb"\x7f'
    assert document["result"] == {"tip": [1.0, "none"]}
    assert path.read_text().startswith("# line\\u000aone\n# tab\there \\ud800\n[design]\n")
    assert load_design(path) == design
    assert comment("a\r\nb") == "# a\\u000d\\u000ab"


def test_a_file_that_does_not_read_back_is_an_error_and_removed(tmp_path, monkeypatch):
    import dpfexplore.io.toml_write as toml_write

    monkeypatch.setattr(toml_write, "read_toml", lambda path, kind: {"design": {"H": [5.0]}})
    with pytest.raises(TomlWriteError, match=r"d.toml: written, it reads back differently at "):
        write_toml(tmp_path / "d.toml", {"design": {"H": [4.0]}}, kind="design")
    assert not (tmp_path / "d.toml").exists()


def test_a_scene_name_with_a_newline_gives_design_files_that_read_back(tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    assert main(["design", str(scene), "--out", str(out)]) in (0, 1)
    capsys.readouterr()
    (written,) = sorted(out.glob("*.toml"))
    assert written.read_text().startswith("# line\\u000aone: target 1")
    assert load_design(written).n_units == 2


def test_lookup_write_from_a_dataset_named_with_a_newline_reads_back(dataset, tmp_path, capsys):
    out = tmp_path / "found"
    assert main(["lookup", str(dataset), "--target", "25,20", "--k", "2", "--write", str(out)]) == 0
    capsys.readouterr()
    files = sorted(out.glob("candidate-*.toml"))
    assert len(files) == 2
    text = files[0].read_text()
    assert text.startswith("# dpfexplore lookup ") and "data\\u000aset: candidate 1" in text
    assert load_design(files[0]).name == "candidate-01"


# ----------------------------------------------------------------------------- a full disk


def test_a_full_disk_under_lookup_write_is_one_line_and_leaves_nothing(
    dataset, tmp_path, capsys, monkeypatch
):
    out = tmp_path / "found"
    assert main(["lookup", str(dataset), "--target", "25,20", "--k", "2"]) == 0  # the index
    capsys.readouterr()
    _full_disk(monkeypatch)
    code = main(["lookup", str(dataset), "--target", "25,20", "--k", "2", "--write", str(out)])
    assert code == 1
    err = _one_line(capsys.readouterr().err, "dpfexplore lookup: error: cannot write ")
    assert "No space left on device" in err and ".tmp" not in err and "staging" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".found")]


def test_a_full_disk_under_design_out_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.replace('"line\\none"', '"full"'))
    out = tmp_path / "out"
    _full_disk(monkeypatch)
    assert main(["design", str(scene), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    _one_line(err, "dpfexplore design: error: cannot write ")
    assert "No space left on device" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


# ----------------------------------------------------------------------------- one line


def test_states_that_all_fail_say_why_in_one_line(tmp_path, capsys):
    path = tmp_path / "far.toml"
    path.write_text("[design]\nH = [4.0, 4.5]\nU_L = 1e300\nU_sep = 2\nt = 0.8\nt_lim = 1.2\n")
    assert main(["states", str(path)]) == 1
    err = _one_line(capsys.readouterr().err, "dpfexplore states: 4 of 4 states not solved (")
    assert "00, 01: nonfinite" in err and "their outputs are nan" in err


def test_a_400_digit_integer_in_a_design_is_one_line(tmp_path, capsys):
    path = tmp_path / "e.toml"
    path.write_text(
        "[design]\nH = [4.0]\nU_L = 7\nU_sep = 2\nt = 0.8\nt_lim = 1.2\nE = 1" + "0" * 399 + "\n"
    )
    assert main(["states", str(path)]) == 2
    err = _one_line(capsys.readouterr().err, f"dpfexplore states: error: {path}: [design] E = ")
    assert err.endswith("an integer of 1326 bits: too large")


def test_a_target_too_far_to_measure_is_refused_without_a_warning(dataset, capsys):
    assert main(["lookup", str(dataset), "--target", "1e300,20"]) == 2
    err = _one_line(capsys.readouterr().err, "dpfexplore lookup: error: target tip_x = 1e+300: ")
    assert "Warning" not in err and "farther from every row" in err


@pytest.mark.parametrize(
    ("where", "outcome"),
    [
        (" or ".join(["t>0"] * 500), "rows"),
        ("&".join(["(t>0)"] * 500), "rows"),
        ("+".join(["tip_x"] * 500) + " > 0", "rows"),
        ("-" * 500 + "tip_x > 0", "nested too deeply (more than 64 levels"),
        ("tip_x > " + "9" * 3000, "a number beyond double precision"),
    ],
)
def test_a_500_term_where_is_one_line_or_an_answer(dataset, capsys, where, outcome):
    code = main(["query", str(dataset), "--where", where, "--columns", "tip_x"])
    out, err = capsys.readouterr()
    if outcome == "rows":
        assert code == 0 and "rows)" in out and err == ""
    else:
        assert code == 2
        err = _one_line(err, "dpfexplore query: error: --where '")
        assert outcome in err and len(err) < 400


def test_a_sweep_plan_too_large_is_refused_before_anything_is_allocated(tmp_path, capsys):
    job = make_job(**{"job.samples_per_n": 100_000_000, "job.chunk_size": 16})
    with pytest.raises(PlanTooLarge, match=r"12500000 chunks, more than the 262144"):
        check_plan(job, {n: 16 for n in job.space.n_units})
    assert MAX_CHUNKS == 262144
    path = tmp_path / "big.toml"
    shutil.copy(os.path.join(os.path.dirname(__file__), "..", "..", "jobs", "smoke.toml"), path)
    path.write_text(path.read_text().replace("samples_per_n = 40", "samples_per_n = 100000000"))
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = _one_line(capsys.readouterr().err, "dpfexplore sweep: error: job.samples_per_n = ")
    assert "give a chunk size (job.chunk_size or --chunk-size) >= 1145" in err
    assert not (tmp_path / "out").exists()


def test_a_full_disk_under_identify_fit_is_one_line_and_leaves_nothing(
    tmp_path, capsys, monkeypatch
):
    import numpy as np

    from dpfexplore.identification.synthetic import synthetic_curves

    table = tmp_path / "curves.csv"
    synthetic_curves(np.linspace(3, 5, 3), np.linspace(0.5, 1, 2), [5.0], [26]).to_csv(
        table, index=False
    )
    out = tmp_path / "constants" / "mine"
    _full_disk(monkeypatch)
    argv = ["identify", "fit", str(table), "--out", str(out), "--method", "least_squares"]
    assert main([*argv, "--degree", "1", "--selector", "lasso"]) == 1  # the smallest fit
    err = _one_line(capsys.readouterr().err, f"dpfexplore identify: error: cannot write {out}")
    assert "No space left on device" in err
    assert list((tmp_path / "constants").iterdir()) == []
