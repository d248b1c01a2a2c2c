"""``dpfexplore bench unitcell``: one JSON record with time and mesh error per mesh."""

from __future__ import annotations

import json

from dpfexplore.bench import unitcell as bench
from dpfexplore.cli import main


def test_bench_record(monkeypatch, capsys):
    monkeypatch.setattr(bench, "DOMES", ((3.0, 1.0),))
    monkeypatch.setattr(bench, "REFERENCE_ELEMENTS", 256)
    monkeypatch.setattr(bench, "SOLID_DOMES", ((3.0, 1.0),))
    monkeypatch.setattr(bench, "TWO_UNIT_DOMES", ((3.0, 1.0), (5.0, 1.0)))
    grid = ["--grid", "6", "--workers", "1"]
    code = main(["bench", "unitcell", "--no-compile", "--repeats", "1", "--json", *grid])
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and record["benchmark"] == "unitcell"
    rows = {r["elements"]: r for r in record["rows"]}
    assert rows[128]["max_energy_error"] < 1e-3
    assert rows[32]["max_energy_error"] > rows[128]["max_energy_error"]
    assert record["compile_s"] is None
    # side by side with the scikit-fem solid: a few percent apart (tests/unitcell/
    # test_solid_check.py holds the comparison itself), and slower than the shell
    (solid,) = record["solid_side_by_side"]
    assert solid["max_energy_difference"] < 0.05
    assert solid["solid_cpu_s"] > solid["shell_s"]
    # the two-unit run beside the curve: timed by the benchmark, its mesh error small on a dome
    # whose run converges (5, 1); the thick low dome (3, 1) has no inverted rest in its plate
    # (test_edge_contact.py)
    two_unit = record["two_unit"]
    assert two_unit["domes_with_rest"] == 1 and two_unit["max_tip_dis_error_mm"] < 1e-3
    assert 0.0 < two_unit["median_s"] <= two_unit["max_s"]
    # the grid goal's sweep: 3 H x 2 t geometries of the box, every one traced
    grid = record["grid_sweep"]
    assert grid["grid"] == [3, 2] and grid["curves"] == 6
    assert sum(grid["statuses"].values()) == 6 and grid["wall_s"] > 0.0
