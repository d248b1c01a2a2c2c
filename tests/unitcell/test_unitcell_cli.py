"""``dpfexplore unitcell curve``: text, one JSON document, the identify table, one-line errors."""

from __future__ import annotations

import json

import pandas as pd

from dpfexplore.cli import main
from dpfexplore.identification.curves import read_curves


def test_curve_json_is_one_document_with_the_series(capsys):
    code = main(["unitcell", "curve", "--H", "3", "--t", "0.83", "--elements", "32", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    document = json.loads(out)
    series = document["series"]
    assert series["displacement"][0] == 0.0
    assert len(series["force"]) == len(series["energy"]) == document["summary"]["steps"]
    assert document["summary"]["bistable"] is True and document["summary"]["tip_kind"] == "rest"
    # the first steps resolve the small-deflection slope
    d, f = series["displacement"], series["force"]
    assert d[1] < 0.05 * 3.0
    assert abs(f[1] / d[1] / document["summary"]["initial_stiffness"] - 1.0) < 0.05


def test_curve_text_and_identify_table(tmp_path, capsys):
    table = tmp_path / "curves" / "one.csv"
    figure = tmp_path / "one.png"
    code = main(
        [
            "unitcell",
            "curve",
            "--H",
            "3",
            "--t",
            "1",
            "--elements",
            "32",
            "--out",
            str(table),
            "--plot",
            str(figure),
        ]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "stable inverted rest (tip_dis)" in out and "folds in apex travel" in out
    assert figure.stat().st_size > 0
    (curve,) = read_curves(table)
    assert curve.folded and curve.tip_dis is not None
    assert set(pd.read_csv(table)["branch"]) == set(
        range(int(pd.read_csv(table)["branch"].max()) + 1)
    )


def test_a_monostable_dome_says_where_its_tip_dis_comes_from(capsys):
    assert main(["unitcell", "curve", "--H", "1.1", "--t", "1", "--elements", "32"]) == 0
    out = capsys.readouterr().out
    assert "stable inverted rest: none (monostable); tip_dis from its ghost" in out
    assert main(["unitcell", "curve", "--H", "1.1", "--t", "1", "--elements", "32", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["summary"]
    assert summary["tip_kind"] == "ghost" and summary["bistable"] is False
    assert 1.5 * 1.1 < summary["tip_dis"] < 2.0 * 1.1


def test_bad_input_is_one_line_exit_2(capsys):
    code = main(["unitcell", "curve", "--H", "3", "--t", "0.83", "--r-b", "-1"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip().count("\n") == 0 and "--r-b" in err
