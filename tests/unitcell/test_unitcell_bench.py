"""``dpfexplore bench unitcell``: one JSON record with time and mesh error per mesh."""

from __future__ import annotations

import json

from dpfexplore.bench import unitcell as bench
from dpfexplore.cli import main


def test_bench_record(monkeypatch, capsys):
    monkeypatch.setattr(bench, "DOMES", ((3.0, 1.0),))
    monkeypatch.setattr(bench, "REFERENCE_ELEMENTS", 256)
    code = main(["bench", "unitcell", "--no-compile", "--repeats", "1", "--json"])
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and record["benchmark"] == "unitcell"
    rows = {r["elements"]: r for r in record["rows"]}
    assert rows[128]["max_energy_error"] < 1e-3
    assert rows[32]["max_energy_error"] > rows[128]["max_energy_error"]
    assert record["compile_s"] is None
