"""No file replaced silently: ``unitcell curve --out/--plot`` and ``bench NAME --save``.

The rule of ``design --out`` and ``lookup --write``: a file already there is refused in one line
naming it and ``--force``, before any work, and left as it was; ``--force`` replaces it.
"""

from __future__ import annotations

import pandas as pd
import pytest

from dpfexplore.cli import main
from dpfexplore.cli.bench import BENCHMARKS, saved_record

CURVE = ["unitcell", "curve", "--H", "3", "--t", "0.83", "--elements", "32"]


def _refused(capsys, argv, *needles):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and "\n" not in err.strip() and "Traceback" not in err, err
    for needle in (*needles, "use --force to replace it"):
        assert needle in err, err


@pytest.mark.parametrize("option, name", [("--out", "dome.csv"), ("--plot", "dome.png")])
def test_unitcell_curve_refuses_an_existing_file(option, name, capsys, tmp_path):
    target = tmp_path / name
    target.write_bytes(b"earlier")
    _refused(capsys, [*CURVE, option, str(target)], f"{option} {target}: the file exists")
    assert target.read_bytes() == b"earlier"


def test_unitcell_curve_force_replaces(capsys, tmp_path):
    table = tmp_path / "dome.csv"  # --plot goes through the same check (the figure costs 1-2 s)
    table.write_bytes(b"earlier")
    assert main([*CURVE, "--out", str(table), "--force"]) == 0
    capsys.readouterr()
    frame = pd.read_csv(table)
    assert {"displacement", "force", "energy"} <= set(frame.columns) and len(frame) > 10
    # a new name needs no --force
    assert main([*CURVE, "--out", str(tmp_path / "new.csv")]) == 0


@pytest.mark.parametrize("module", BENCHMARKS)
def test_bench_save_refuses_an_existing_record(module, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = module.replace("_", "-")
    record = saved_record(name, type("Args", (), {})())
    record.parent.mkdir(parents=True)
    record.write_text('{"earlier": true}\n')
    _refused(capsys, ["bench", name, "--save"], f"--save {record}: the file exists")
    assert record.read_text() == '{"earlier": true}\n'


def test_bench_save_as_names_the_record(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    record = tmp_path / "results" / "reports" / "bench-design-timing.json"
    record.parent.mkdir(parents=True)
    record.write_text("{}\n")
    _refused(
        capsys,
        ["bench", "design", "--save", "--save-as", record.name],
        "bench-design-timing.json: the file exists",
    )
