"""Inputs are checked before the work starts: one line naming the file, key or option, exit 2.

Each case here used to be refused only after minutes of work, or with a traceback.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from dpfexplore import Design, find_state
from dpfexplore.cli import main

ROOT = Path(__file__).parents[2]
POSITION = (ROOT / "jobs" / "design-position-cheetah.toml").read_text()
GRIPPER_SCENE = (ROOT / "jobs" / "design-gripper.toml").read_text()
GRIPPER = ROOT / "dpfexplore" / "examples" / "gripper.toml"
WALKER = ROOT / "dpfexplore" / "examples" / "walker-leg.toml"


def refused(capsys, argv: list[str], *needles: str) -> str:
    started = time.perf_counter()
    assert main(argv) == 2
    seconds = time.perf_counter() - started
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err
    assert seconds < 30, f"refused only after {seconds:.0f} s"
    return err


SCENES = {
    "kind-list": (POSITION.replace('kind = "position"', 'kind = ["position"]'), "scene.kind"),
    "nu": (
        POSITION.replace('material = "cheetah-95a"', "E = 20.0\nnu = 0.7"),
        "scene.nu = 0.7",
    ),
    "far-target": (
        POSITION.replace("point = [46.0, 32.0]", "point = [1e300, 1e300]"),
        "targets[0].point",
    ),
    "empty-box": (
        POSITION.replace("U_L = {min = 5.5, max = 10.0}", "U_L = {min = 0.001, max = 0.002}"),
        "holds no valid design",
    ),
    "gripper-pulse": (
        GRIPPER_SCENE.replace("pulse = {P0 = 0.7,", "pulse = {P0 = 5.0,"),
        "gripper.pulse",
    ),
}


@pytest.mark.parametrize("case", sorted(SCENES))
def test_scene_values_are_refused_before_solving(case, tmp_path, capsys):
    text, needle = SCENES[case]
    assert text != (GRIPPER_SCENE if case == "gripper-pulse" else POSITION)
    scene = tmp_path / f"{case}.toml"
    scene.write_text(text)
    refused(capsys, ["design", str(scene), "--out", str(tmp_path / "out")], needle)
    assert not (tmp_path / "out").exists()


DESIGN_FILES = {
    "number": (b"design = 3\n", "[design] must be a table"),
    "list": (b"design = [1, 2]\n", "[design] must be a table"),
    "string": (b'design = "x"\n', "[design] must be a table"),
    "binary": (bytes(range(256)), "not a text file"),
    "ragged": (
        b"[design]\nH = [[3, 4], [5]]\nU_L = 10\nU_sep = 2\nt = 0.7\nt_lim = 1\n",
        "H[unit 1]",
    ),
}


@pytest.mark.parametrize("case", sorted(DESIGN_FILES))
def test_design_files_name_the_file_and_key(case, tmp_path, capsys):
    content, needle = DESIGN_FILES[case]
    path = tmp_path / f"{case}.toml"
    path.write_bytes(content)
    refused(capsys, ["states", str(path)], str(path), needle)


@pytest.mark.parametrize(
    ("option", "needle"),
    [
        (["--tau", "nan,1,2,3"], "--tau"),
        (["--tau", "0,1,2,inf"], "--tau"),
        (["--P0", "3"], "P0 = 3"),
    ],
)
def test_reset_model_fit_options_are_checked_first(option, needle, tmp_path, capsys):
    refused(capsys, ["reset-model", "fit", "--out", str(tmp_path / "m.json"), *option], needle)


def test_reset_model_fit_output_folder_is_checked_first(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    refused(capsys, ["reset-model", "fit", "--out", str(tmp_path / "afile" / "m.json")], "afile")


def test_snap_pressure_stops_where_every_entry_point_stops(capsys):
    refused(capsys, ["snap", str(GRIPPER), "--P-max", "3"], "P_max = 3")


def test_simulate_leg_set_names_the_section(capsys):
    refused(capsys, ["simulate-leg", str(WALKER), "--set", "purple.H=nan"], "section 'purple'")


@pytest.mark.parametrize("state", [None, 2.5, object()])
def test_find_state_refuses_a_state_that_is_no_state(state):
    design = Design(H=[3.5, 4.0], U_L=8.0, U_sep=2.0, t=0.7, t_lim=1.2)
    with pytest.raises(ValueError, match=re.escape("state = ")):
        find_state(design, state)


@pytest.mark.parametrize("name", ["..", ".", " "])
def test_a_scene_name_must_name_a_folder_of_its_own(name, tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(POSITION.replace('name = "design-position-cheetah"', f"name = {name!r}"))
    refused(capsys, ["design", str(scene)], "scene.name")


def test_figure_paths_are_checked_before_the_work(tmp_path, capsys):
    folder = tmp_path / "figures"
    folder.mkdir()
    refused(capsys, ["states", str(GRIPPER), "--plot", str(folder)], "--plot", "is a directory")
    refused(capsys, ["snap", str(GRIPPER), "--plot", str(tmp_path / "x.txt")], ".png")
    refused(capsys, ["simulate-leg", str(WALKER), "--plot", str(tmp_path / "noext")], ".png")
    (tmp_path / "afile").write_text("x")
    refused(capsys, ["states", str(GRIPPER), "--plot", str(tmp_path / "afile" / "p.png")], "afile")
    assert not (tmp_path / "noext.png").exists() and not (tmp_path / "x.txt").exists()
    assert main(["states", str(GRIPPER), "--plot", str(tmp_path / "new" / "sub" / "s.png")]) == 0
    assert (tmp_path / "new" / "sub" / "s.png").stat().st_size > 0


def test_a_sweep_job_given_to_design_is_named_as_such(capsys):
    refused(capsys, ["design", str(ROOT / "jobs" / "smoke.toml")], "sweep job", "dpfexplore sweep")
