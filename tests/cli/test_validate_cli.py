"""``dpfexplore validate`` (issue 31 §1): table, --json, --plot, --report, --record, refusals."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from dpfexplore.cli import main
from dpfexplore.model.constants_set import PACKAGED_DIR, load_constants_set

ROOT = Path(__file__).parents[2]
PAPER = ROOT / "dpfexplore" / "data" / "measurements" / "paper.toml"


@pytest.fixture(autouse=True)
def in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


def test_the_default_run_prints_the_table_and_the_summary(capsys):
    code = main(["validate"])
    out = capsys.readouterr().out.splitlines()
    assert code == 1  # shell-extended fails the goal
    assert out[0].startswith("validate: 13 fingers of dpfexplore/data/measurements/paper.toml")
    assert "find_state" in out[1]
    assert out[-1].startswith("validate: 'paper': mean tip distance 5.86 mm NinjaFlex 85A")
    assert "'shell-extended'" in out[-1] and out[-1].endswith("(FAILS the goal)")
    assert any(line.startswith("cheetah-target-2 ") and " 25.17 " in line for line in out)


def test_json_of_one_set(capsys):
    assert main(["validate", "--constants", "paper", "--json"]) == 0
    document = json.loads(capsys.readouterr().out, parse_constant=pytest.fail)
    assert [s["name"] for s in document["sets"]] == ["paper"]
    assert len(document["fingers"]) == 13 and document["verdicts"][0]["passes"] is True
    first = document["fingers"][0]
    assert first["finger"] == "ninjaflex-target-1" and first["holds"] is True
    assert first["distance"] == pytest.approx(5.145, abs=1e-3)
    assert first["measured_tip"] == [42.9, 37.7]


def test_sets_by_name_and_file(tmp_path, capsys):
    copy = shutil.copy(PACKAGED_DIR / "shell-extended.json", tmp_path / "mine.json")
    argv = ["validate", "--constants", "paper", "--constants", str(copy), "--json"]
    assert main(argv) == 1
    document = json.loads(capsys.readouterr().out)
    assert [s["name"] for s in document["sets"]] == ["paper", "shell-extended"]
    assert main(["validate", "--constants", "paper", "paper"]) == 2
    assert "two sets are named 'paper'" in capsys.readouterr().err
    assert main(["validate", "--constants", "nosuch"]) == 2
    assert "--constants nosuch: no such constants set" in capsys.readouterr().err


def test_plot_and_report(tmp_path, capsys):
    code = main(["validate", "--plot", "fig/v.png", "--report", "pages/v.md"])
    assert code == 1
    png, page = tmp_path / "fig" / "v.png", (tmp_path / "pages" / "v.md").read_text()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50_000
    assert "dpfexplore validate --plot fig/v.png --report pages/v.md" in page
    assert "](../fig/v.png)" in page  # linked relative to the page
    assert "| shell-extended | Cheetah 95A | 3/8 |" in page


def test_own_measurement_file(tmp_path, capsys):
    text = PAPER.read_text().split("position-only designs, Cheetah 95A")[0]
    (tmp_path / "ninja.toml").write_text(text)
    assert main(["validate", "ninja.toml", "--constants", "paper", "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert len(document["fingers"]) == 5
    assert document["measurements"][0]["path"] == "ninja.toml"


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["validate", "missing.toml"], "missing.toml: no such measurement file"),
        (["validate", "bad.toml"], "bad.toml: finger 1 ('a'), state = '1': need 2 characters"),
        (["validate", "--plot", "v.txt"], "--plot v.txt: give a file name ending in"),
        (["validate", "--report", "v.html"], "--report v.html: give a file name ending in .md"),
        (["validate", "x.toml", "--record"], "--record: a verdict is on the packaged"),
        (["validate", "--constants", "paper", "--record"], "--record: name a set file"),
    ],
)
def test_bad_input_is_one_line_and_nothing_is_computed(tmp_path, capsys, monkeypatch, argv, says):
    (tmp_path / "bad.toml").write_text(
        'format = "dpfexplore-measurements/1"\n[[finger]]\nname = "a"\nmaterial = "cheetah-95a"\n'
        'H = [4.5, 4.2]\nU_L = 7.0\nU_sep = 1.0\nt = 0.8\nt_lim = 1.2\nstate = "1"\n'
        'tip = [1.0, 2.0]\nprovenance = "x"\n'
    )
    import dpfexplore.measurements as measurements

    def no_work(*args, **kwargs):
        raise AssertionError("computed before refusing")

    monkeypatch.setattr(measurements, "validate", no_work)
    assert main([*argv, "--plot", "out.png"] if "--plot" not in argv else argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert says in err and "\n" not in err, err
    assert captured.out == "" and not (tmp_path / "out.png").exists()


def test_record_writes_the_verdict_into_a_set_file(tmp_path, capsys):
    copy = tmp_path / "mine.json"
    data = json.loads((PACKAGED_DIR / "shell-extended.json").read_text())
    data.pop("validation", None)
    copy.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    assert main(["validate", "--constants", "paper", str(copy), "--record"]) == 1
    out = capsys.readouterr().out
    assert out.splitlines()[-1] == f"verdicts recorded in {copy}"
    recorded = load_constants_set(copy).validation
    assert recorded["passes"] is False and recorded["set_fingerprint"] == data["fingerprint"]
    assert recorded["summary"] in out
