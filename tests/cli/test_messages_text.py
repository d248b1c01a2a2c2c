"""One-line refusals that name the option and what to do, in words rather than Python reprs."""

from __future__ import annotations

from pathlib import Path

import pytest

from dpfexplore.cli import main
from dpfexplore.model.design import load_design

ROOT = Path(__file__).parents[2]


@pytest.mark.parametrize(
    ("path", "command"),
    [
        ("jobs/design-gripper.toml", "dpfexplore design"),
        ("jobs/walker-purple.toml", "dpfexplore states"),
    ],
)
def test_sweep_on_another_command_s_file_names_that_command(tmp_path, capsys, path, command):
    assert main(["sweep", str(ROOT / path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and f"run it with: {command} " in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("engine", ["local", "dask"])
def test_workers_below_one_is_named_as_the_option(tmp_path, capsys, engine):
    argv = ["sweep", str(ROOT / "jobs" / "smoke.toml"), "--out", str(tmp_path / "o")]
    assert main([*argv, "--workers", "0", "--engine", engine]) == 2
    err = capsys.readouterr().err
    assert "--workers 0: must be >= 1" in err and "threads =" not in err


def test_key_lists_read_as_words(tmp_path):
    path = tmp_path / "d.toml"
    path.write_text(
        "[design]\nH = [3.0, 4.0]\nU_L = 6.0\nU_sep = 1.0\nt = 0.8\nt_lim = 1.0\nHH = 1\n"
    )
    with pytest.raises(ValueError, match="unknown design key; known: ") as caught:
        load_design(path)
    assert (
        "[" not in str(caught.value).partition("known:")[2]
        and "'" not in str(caught.value).partition("known:")[2]
    )
