"""Every entry point runs on a constants set (issue 20 §1): ``--constants FILE`` and
``constants = "FILE"`` in design, job and scene files, with the refusals that keep results of
two sets apart (a sweep resumed under another set, a lookup or a surrogate of another set)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from model_helpers import other_set
from sweep_helpers import job_dict, toml_text

from dpfexplore import Design, find_state
from dpfexplore.cli import main
from dpfexplore.model.constants_set import DEFAULT
from dpfexplore.model.design import DesignBatch, load_design
from dpfexplore.solvers.dynamics.reset_model import load_reset_model
from dpfexplore.surrogates.store import SurrogateLoadError, check_compatible
from dpfexplore.sweep.storage.datasets import dataset_info

ROOT = Path(__file__).parents[2]
GRIPPER = ROOT / "dpfexplore" / "examples" / "gripper.toml"
WALKER = ROOT / "dpfexplore" / "examples" / "walker-leg.toml"
POSITION = (ROOT / "jobs" / "design-position-cheetah.toml").read_text()


@pytest.fixture
def sets(tmp_path):
    """The test's other set and the paper's, as files."""
    return {
        "other": other_set().save(tmp_path / "other.json"),
        "paper": DEFAULT.save(tmp_path / "paper.json"),
    }


def run_json(capsys, argv):
    code = main(argv)
    out = capsys.readouterr().out
    return code, json.loads(out)


def refused(capsys, argv, *needles):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


def test_states_runs_on_the_given_set(capsys, sets):
    code, paper = run_json(capsys, ["states", str(GRIPPER), "--sequential", "--json"])
    assert code == 0 and paper["constants"]["fingerprint"] == DEFAULT.fingerprint
    code, other = run_json(
        capsys,
        ["states", str(GRIPPER), "--sequential", "--json", "--constants", str(sets["other"])],
    )
    assert code == 0 and other["constants"]["name"] == "other"
    # the same result as the Python API under that set, and not the paper's
    design = load_design(GRIPPER).replace(constants=other_set())
    last = other["states"][-1]
    want = find_state(design, last["state"])
    assert last["energy"] == pytest.approx(want.energy, rel=1e-9)
    assert abs(last["energy"] - paper["states"][-1]["energy"]) > 1e-3


def test_a_design_file_naming_a_set_and_another_constants_option_is_refused(capsys, sets, tmp_path):
    text = GRIPPER.read_text().replace("[design]", '[design]\nconstants = "other.json"', 1)
    (tmp_path / "finger.toml").write_text(text)
    assert load_design(tmp_path / "finger.toml").constants == other_set()
    refused(
        capsys,
        ["states", str(tmp_path / "finger.toml"), "--constants", str(sets["paper"])],
        "--constants names constants set 'paper'",
        "'other'",
    )
    # the same set twice is no conflict
    assert main(["states", str(tmp_path / "finger.toml"), "--constants", str(sets["other"])]) == 0
    capsys.readouterr()


def test_a_tampered_set_is_refused_by_every_command(capsys, sets, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(sets["other"].read_text().replace('"other"', '"edited"'))
    for argv in (
        ["states", str(GRIPPER)],
        ["simulate", str(GRIPPER)],
        ["snap", str(GRIPPER)],
        ["simulate-leg", str(WALKER)],
    ):
        refused(capsys, [*argv, "--constants", str(bad)], "--constants", "fingerprint")


def test_simulate_snap_and_legs_take_the_set(capsys, sets):
    _, run = run_json(
        capsys,
        ["simulate", str(GRIPPER), "--json", "--constants", str(sets["other"])],
    )
    assert run["constants"]["name"] == "other"
    _, snap = run_json(capsys, ["snap", str(GRIPPER), "--json", "--constants", str(sets["other"])])
    assert snap["constants"]["name"] == "other"
    _, leg = run_json(
        capsys, ["simulate-leg", str(WALKER), "--json", "--constants", str(sets["other"])]
    )
    # the walker's low domes (H/r_b = 0.22) lie outside this set's domain too: flagged
    assert leg["sections"][0]["fitted_range"] is False


def sweep_job(tmp_path, **changes) -> Path:
    data = job_dict(**{"job.samples_per_n": 12, "space.n_units": [2], **changes})
    path = tmp_path / "job.toml"
    path.write_text(toml_text(data))
    return path


def test_a_sweep_records_its_set_and_refuses_another_on_resume(capsys, sets, tmp_path):
    job = sweep_job(tmp_path, **{"job.constants": "other.json"})
    out = tmp_path / "out"
    assert main(["sweep", str(job), "--out", str(out)]) == 0
    capsys.readouterr()
    info = dataset_info(out)
    assert info.constants == {"name": "other", "fingerprint": other_set().fingerprint}
    assert info.constants_set() == other_set()
    # rows under the set: the stored tips are the exact model's under it
    import pandas as pd

    rows = pd.read_parquet(out).sort_values("design_id")
    design = DesignBatch(
        n_units=np.array([2]),
        H=np.pad([rows.H_1.iloc[0], rows.H_2.iloc[0]], (0, 10), constant_values=np.nan)[None],
        U_L=np.pad([rows.U_L_1.iloc[0], rows.U_L_2.iloc[0]], (0, 10), constant_values=np.nan)[None],
        U_sep=np.pad([rows.U_sep_1.iloc[0], rows.U_sep_2.iloc[0]], (0, 10), constant_values=np.nan)[
            None
        ],
        t=rows.t.iloc[0],
        t_lim=rows.t_lim.iloc[0],
        E=rows.E.iloc[0],
        nu=rows.nu.iloc[0],
        r_b=rows.r_b.iloc[0],
        t_ch=rows.t_ch.iloc[0],
        constants=other_set(),
    ).design(0)
    tip = find_state(design, "11").tip
    assert rows.tip_x.iloc[0] == pytest.approx(tip[0], abs=1e-9)
    # resume under the paper's set: refused, naming both
    refused(
        capsys,
        ["sweep", str(job), "--out", str(out), "--resume", "--constants", str(sets["paper"])],
        "--constants names constants set 'paper'",
    )
    (tmp_path / "plain").mkdir()
    plain = sweep_job(tmp_path / "plain")
    refused(
        capsys,
        ["sweep", str(plain), "--out", str(out), "--resume"],
        "holds rows computed under constants set 'other'",
        "'paper'",
    )
    # a lookup under another set is refused before any work; under its own it re-solves
    refused(
        capsys,
        ["lookup", str(out), "--target", "40,30", "--constants", str(sets["paper"])],
        "computed under constants set 'other'",
        "'paper'",
    )
    written = tmp_path / "found"
    code, found = run_json(
        capsys, ["lookup", str(out), "--target", "40,30", "--json", "--write", str(written)]
    )
    assert code in (0, 1) and found["candidates"]
    # the job's set file moved away: the dataset names it, and a --constants with the same set
    # (checked by fingerprint) stands in for it
    moved = sets["other"].rename(tmp_path / "elsewhere.json")
    refused(capsys, ["lookup", str(out), "--target", "40,30"], "pass --constants FILE")
    code, again = run_json(
        capsys, ["lookup", str(out), "--target", "40,30", "--json", "--constants", str(moved)]
    )
    assert code in (0, 1) and again["candidates"] == found["candidates"]
    from dpfexplore.sweep.job_file import recorded_space

    assert recorded_space(dataset_info(out).job).n_units == (2,)
    # the written designs read back under the set they were verified with
    first = load_design(written / "candidate-01.toml")
    assert first.constants == other_set()
    assert find_state(first, found["candidates"][0]["state"]).tip[0] == pytest.approx(
        found["candidates"][0]["tip"][0], abs=1e-9
    )


def test_a_design_scene_runs_on_its_set(capsys, sets, tmp_path):
    scene = POSITION.replace(
        'material = "cheetah-95a"', 'material = "cheetah-95a"\nconstants = "other.json"'
    )
    (tmp_path / "scene.toml").write_text(scene)
    out = tmp_path / "report"
    code = main(["design", str(tmp_path / "scene.toml"), "--out", str(out)])
    capsys.readouterr()
    assert code in (0, 1)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["constants"] == {"name": "other", "fingerprint": other_set().fingerprint}
    assert load_design(out / "target-01.toml").constants == other_set()
    refused(
        capsys,
        [
            "design",
            str(tmp_path / "scene.toml"),
            "--out",
            str(tmp_path / "r2"),
            "--constants",
            str(sets["paper"]),
        ],
        "--constants names constants set 'paper'",
    )


def test_surrogates_and_the_reset_model_refuse_another_set():
    meta = {
        "surrogate_version": None,
        "dataset": {"fingerprint": {"constants": {"name": "other", "fingerprint": "f" * 64}}},
    }
    from dpfexplore.surrogates.store import SURROGATE_VERSION

    meta["surrogate_version"] = SURROGATE_VERSION
    from dpfexplore.model.version import MODEL_VERSION

    meta["model_version"] = MODEL_VERSION
    import sklearn

    meta["versions"] = {"scikit-learn": sklearn.__version__}
    with pytest.raises(
        SurrogateLoadError, match=r"constants set 'other' \(ffffffffffff\), not 'paper'"
    ):
        check_compatible(meta, constants=DEFAULT)
    check_compatible({**meta, "dataset": {"fingerprint": {}}}, constants=DEFAULT)  # paper's
    model = load_reset_model()
    model.check_constants(DEFAULT)
    with pytest.raises(ValueError, match="trained on designs of constants set 'paper'"):
        model.check_constants(other_set())
    batch = DesignBatch.from_designs(
        [Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0, constants=other_set())]
    )
    from dpfexplore.model.pressure import PressureProfile
    from dpfexplore.solvers.dynamics.fast_reset import fast_reset_times_batch

    with pytest.raises(ValueError, match="constants set"):
        fast_reset_times_batch(
            batch,
            PressureProfile.pulse(model.P0, model.tau),
            t_end=model.tau[3] + 1.0,
            full_model=None,
        )
