"""``dpfexplore identify``: fit, report, compare; a bad table is one line and nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from plotting.figure_checks import assert_readable, captured_figures

from dpfexplore.cli import main
from dpfexplore.identification.synthetic import synthetic_curves
from dpfexplore.io.result_dirs import verify_result_dir
from dpfexplore.model.constants_set import DEFAULT, load_constants_set


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    path = tmp_path_factory.mktemp("identify") / "curves.csv"
    frame = synthetic_curves(np.linspace(3, 5, 6), np.linspace(0.5, 1, 5), [5.0], [12, 26])
    frame.to_csv(path, index=False)
    return path


def test_fit_report_compare(table, tmp_path, capsys):
    out = tmp_path / "constants" / "mine"
    argv = ["identify", "fit", str(table), "--out", str(out), "--method", "least_squares"]
    with captured_figures() as figures:
        assert main([*argv, "--plot", "--json"]) == 0
    (selection,) = figures
    assert_readable(selection)
    report = json.loads(capsys.readouterr().out)
    assert report["curves"] == 60 and report["curves_flagged"] == 0
    verify_result_dir(out)
    constants = load_constants_set(out / "constants.json")
    assert constants.name == "mine" and (out / "selection.png").stat().st_size > 0
    values = constants.evaluate(4.0, 0.75, 5.0, 26.0)
    truth = DEFAULT.evaluate(4.0, 0.75, 5.0, 26.0)
    assert float(values["alpha"]) == pytest.approx(float(truth["alpha"]), rel=0.01)

    assert main(["identify", "report", str(out)]) == 0
    text = capsys.readouterr().out
    assert "alpha = " in text and "held-out geometries" in text

    argv = ["identify", "compare", str(out), "--design", "gripper", "--design", "pickplace"]
    assert main([*argv, "--json"]) == 0
    gripper, pickplace = json.loads(capsys.readouterr().out)
    assert len(gripper["units"]) == 5 and gripper["units"][0]["paper:class"] == "bistable"
    # identification recovers the paper's set: the reference fingers' states to 0.01 mm tip
    for finger in (gripper, pickplace):
        assert len(finger["states"]) == len(finger["units"]) + 1
        assert max(row["tip_shift"] for row in finger["states"]) < 0.01
        for row in finger["states"]:
            assert row["mine:found"] == row["paper:found"]
        classes = [(r["mine:class"], r["paper:class"]) for r in finger["reset_times"]]
        assert all(a == b for a, b in classes), classes
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "sequential states" in text and "reset times" in text

    # a second fit into the same directory needs --force; an edited set is refused
    assert main(["identify", "fit", str(table), "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    path = out / "constants.json"
    path.write_text(path.read_text().replace('"name": "mine"', '"name": "theirs"'))
    assert main(["identify", "report", str(out)]) == 2
    assert "changed" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda f: f.drop(columns=["displacement"]), "missing column"),
        (lambda f: f.assign(t=f["t"] + 0.01 * (f.index % 2)), "changes within"),
    ],
)
def test_bad_tables_are_one_line_and_nothing_is_written(table, tmp_path, capsys, change, says):
    import pandas as pd

    bad = tmp_path / "bad.csv"
    change(pd.read_csv(table)).to_csv(bad, index=False)
    out = tmp_path / "out"
    assert main(["identify", "fit", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and "\n" not in err
    assert not out.exists()


def test_bench_identify_record(capsys):
    args = ["bench", "identify", "--json", "--heights", "4", "--thicknesses", "4"]
    assert main([*args, "--baseline-curves", "5"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["curves"] == 4 * 4 * 2 * 5 and record["flagged"] == 0
    assert record["ours_alpha_error"]["median"] < 0.01
    assert record["baseline_k_b_error"]["failures"] >= 0 and record["total_s"] > 0
