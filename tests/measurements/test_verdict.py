"""A set's verdict in its file (issue 31 §3's mechanism): outside the fingerprint, bound to the
set, announced by every command, refused by ``design`` unless ``--allow-unvalidated``."""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
from pathlib import Path

import pytest
from model_helpers import other_set

from dpfexplore.cli import main
from dpfexplore.measurements.verdict import failed_summary, record_verdict, verdict_of
from dpfexplore.model.constants_set import (
    DEFAULT,
    PACKAGED_DIR,
    ConstantsSetError,
    find_constants_set,
    load_constants_set,
    packaged_sets,
)

SHELL = PACKAGED_DIR / "shell-extended.json"
SCENE = Path(__file__).parents[2] / "jobs" / "design-position-cheetah.toml"


def _verdict(constants, passes=False, **changes):
    return {
        "set_fingerprint": constants.fingerprint,
        "passes": passes,
        "summary": f"constants set {constants.name!r} FAILS (a test's verdict)",
        **changes,
    }


def test_a_verdict_leaves_the_fingerprint_and_the_set_as_they_are(tmp_path):
    plain = other_set()
    judged = dataclasses.replace(plain, validation=_verdict(plain))
    assert judged.fingerprint == plain.fingerprint and judged == plain
    path = judged.save(tmp_path / "judged.json")
    data = json.loads(path.read_text())
    assert data["fingerprint"] == plain.fingerprint and data["validation"]["passes"] is False
    back = load_constants_set(path)
    assert back == plain and back.validation == judged.validation
    # a file without a verdict reads as before, and is not confused with the judged one
    assert load_constants_set(plain.save(tmp_path / "plain.json")).validation is None


def test_a_verdict_on_another_set_is_refused(tmp_path):
    plain = other_set()
    path = dataclasses.replace(plain, validation=_verdict(DEFAULT)).save(tmp_path / "moved.json")
    with pytest.raises(ConstantsSetError, match="validation is not a verdict on this set"):
        load_constants_set(path)
    data = json.loads(path.read_text())
    data["validation"] = {"passes": "no", "set_fingerprint": plain.fingerprint, "summary": "x"}
    path.write_text(json.dumps(data))
    with pytest.raises(ConstantsSetError, match="not a verdict"):
        load_constants_set(path)


def test_reading_a_failed_set_logs_its_summary(tmp_path, caplog):
    plain = other_set()
    path = dataclasses.replace(plain, validation=_verdict(plain)).save(tmp_path / "f.json")
    with caplog.at_level(logging.WARNING, logger="dpfexplore.validation"):
        constants = load_constants_set(path)
    assert [r.getMessage() for r in caplog.records] == [_verdict(plain)["summary"]]
    assert failed_summary(constants) == _verdict(plain)["summary"]
    caplog.clear()
    passed = dataclasses.replace(plain, validation=_verdict(plain, passes=True))
    with caplog.at_level(logging.WARNING, logger="dpfexplore.validation"):
        assert failed_summary(load_constants_set(passed.save(tmp_path / "p.json"))) is None
    assert not caplog.records


def test_record_verdict_writes_the_verdict_into_the_file(tmp_path):
    path = tmp_path / "shell.json"
    data = json.loads(SHELL.read_text())
    data.pop("validation", None)
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    before = load_constants_set(path)
    verdict = record_verdict(path)
    after = json.loads(path.read_text())
    assert {k: v for k, v in after.items() if k != "validation"} == data  # nothing else changed
    assert after["fingerprint"] == before.fingerprint
    assert after["validation"] == verdict.to_dict() and not verdict.passes
    assert after["validation"]["measurements"][0]["file"] == "paper.toml"
    # recording again gives the same bytes; a stale verdict is replaced, not refused
    text = path.read_text()
    record_verdict(path)
    assert path.read_text() == text
    after["validation"]["set_fingerprint"] = "0" * 64
    path.write_text(json.dumps(after))
    record_verdict(path)
    assert path.read_text() == text


@pytest.mark.parametrize(
    "text, reason",
    [
        ("[" * 200_000 + "]" * 200_000, "nested too deeply"),
        ('{"format": NaN}', "NaN is not a number"),
    ],
)
def test_record_verdict_refuses_a_malformed_file_in_one_line_naming_it(tmp_path, text, reason):
    path = tmp_path / "deep.json"
    path.write_text(text)
    with pytest.raises(ConstantsSetError) as refused:
        record_verdict(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: ") and reason in message and "\n" not in message
    assert path.read_text() == text  # nothing written


def test_commands_announce_a_failed_set_in_one_line(tmp_path, capsys):
    path = tmp_path / "other.json"
    plain = other_set()
    dataclasses.replace(plain, validation=_verdict(plain)).save(path)
    assert main(["states", "gripper", "--sequential", "--constants", str(path)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    announced = [line for line in err if "FAILS" in line]
    assert announced == [f"dpfexplore states: {_verdict(plain)['summary']}"]


def test_design_refuses_a_failed_set_unless_allowed(tmp_path, capsys, monkeypatch):
    path = tmp_path / "other.json"
    plain = other_set()
    dataclasses.replace(plain, validation=_verdict(plain)).save(path)
    scene = tmp_path / "scene.toml"
    shutil.copy(SCENE, scene)
    out = tmp_path / "out"
    argv = ["design", str(scene), "--constants", str(path), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("(--allow-unvalidated to design on it anyway)")
    assert "design: error: constants set 'other' FAILS" in err
    assert not out.exists()

    import dpfexplore.inverse.design as design_module

    class Ran(Exception):
        pass

    def ran(*args, **kwargs):
        raise Ran

    monkeypatch.setattr(design_module, "run_design", ran)
    with pytest.raises(Ran):  # past the refusal, into the solve
        main([*argv, "--allow-unvalidated"])


def test_every_packaged_set_carries_its_current_verdict():
    # Main never ships a set that silently mispredicts: each packaged set's file records the
    # verdict validate() gives today on the packaged measurements. After changing a set (or the
    # measurements), record it again: dpfexplore validate --constants NAME --record
    assert packaged_sets()
    for name in packaged_sets():
        constants = find_constants_set(name)
        assert constants.validation is not None, f"{name}: no verdict recorded"
        want = json.loads(json.dumps(verdict_of(constants).to_dict()))
        got = dict(constants.validation)
        assert got.pop("limits_mm") == pytest.approx(want.pop("limits_mm"), rel=1e-9)
        assert got == want, f"{name}: its recorded verdict is stale"


def test_shell_extended_is_marked_failing():
    shell = find_constants_set("shell-extended")
    summary = failed_summary(shell)
    assert summary is not None and "held 5/5 NinjaFlex 85A, 3/8 Cheetah 95A" in summary
    assert shell.fingerprint == json.loads(SHELL.read_text())["fingerprint"]
