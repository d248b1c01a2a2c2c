"""One resolution of constants-set names and paths, for every command that takes a set.

Each command is given the same set three ways: a saved identification's name (``mine``, read
from ``results/constants/mine/constants.json`` in the working directory), that file's path, and a
name that names nothing. The first two run on the set (its name in the output, or a refusal that
can only come from having read it); the third is one line naming the value and listing the
packaged sets.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from model_helpers import other_set
from sweep_helpers import job_dict, toml_text

from dpfexplore.cli import main
from dpfexplore.io.result_dirs import result_directory
from dpfexplore.model.constants_set import (
    DEFAULT,
    PACKAGED_DIR,
    SAVED_DIR,
    ConstantsSetError,
    find_constants_set,
    locate_constants_set,
    packaged_sets,
)
from dpfexplore.model.design import load_design

ROOT = Path(__file__).parents[2]
EXAMPLES = ROOT / "dpfexplore" / "examples"


@pytest.fixture
def saved(tmp_path, monkeypatch):
    """A working directory with a saved identification ``mine`` (the tests' other set)."""
    folder = tmp_path / SAVED_DIR / "mine"
    folder.parent.mkdir(parents=True)
    with result_directory(folder, kind="constants") as staging:  # as identify fit saves
        other_set().save(staging / "constants.json")
        (staging / "report.json").write_text("{}\n")
    monkeypatch.chdir(tmp_path)
    return folder / "constants.json"


def test_one_resolution_order(saved, tmp_path):
    assert locate_constants_set("mine") == SAVED_DIR / "mine" / "constants.json"
    assert locate_constants_set(str(saved.parent)) == saved  # the saved folder itself
    assert locate_constants_set(str(saved)) == saved
    assert locate_constants_set("paper") is None and find_constants_set("paper") is DEFAULT
    for name in packaged_sets():
        assert locate_constants_set(name) == PACKAGED_DIR / f"{name}.json"
    # a TOML file's key is relative to its folder
    assert locate_constants_set("constants.json", base=saved.parent) == saved
    # a saved identification of a packaged set's name wins, as a local file does
    shadow = tmp_path / SAVED_DIR / packaged_sets()[0]
    shadow.mkdir()
    other_set().save(shadow / "constants.json")
    assert find_constants_set(packaged_sets()[0]).name == "other"
    with pytest.raises(ConstantsSetError, match=r"a folder without constants\.json"):
        locate_constants_set(str(tmp_path))
    with pytest.raises(ConstantsSetError) as caught:
        locate_constants_set("nosuch")
    message = str(caught.value)
    assert message.startswith("nosuch: ") and "\n" not in message
    assert "packaged sets: paper, " + ", ".join(packaged_sets()) in message


WALKER = str(EXAMPLES / "walker-leg.toml")
GRIPPER = str(EXAMPLES / "gripper.toml")
SCENE = (ROOT / "jobs" / "design-gripper.toml").read_text()
PACKAGED = packaged_sets()[0]

#: Every command that takes a set, with ``{set}`` where it goes, and how a run on the set shows:
#: "out" prints the set's name in its JSON; "differs" prints results unlike the paper set's
#: (its JSON does not name the set); "refused" is refused for an input computed under, or
#: naming, a packaged set, in a line that names the given set's label (so it was read).
COMMANDS = {
    "states": (["states", GRIPPER, "--json", "--constants", "{set}"], "out"),
    "simulate-leg": (["simulate-leg", WALKER, "--json", "--constants", "{set}"], "differs"),
    "identify compare": (["identify", "compare", "{set}", "--design", GRIPPER, "--json"], "out"),
    "simulate": (["simulate", GRIPPER, "--method", "fast", "--constants", "{set}"], None),
    "snap": (["snap", GRIPPER, "--constants", "{set}"], None),
    "validate": (["validate", "--constants", "{set}"], None),
    "design": (["design", "{scene}", "--constants", "{set}"], "refused"),
    "sweep": (["sweep", "{job}", "--out", "{tmp}/run", "--constants", "{set}"], "refused"),
    "lookup": (["lookup", "{dataset}", "--target", "40,30", "--constants", "{set}"], "refused"),
    "surrogate fit": (
        [
            *("surrogate", "fit", "{dataset}", "--outputs", "tip_x"),
            *("--out", "{tmp}/s", "--constants", "{set}"),
        ],
        "refused",
    ),
    "surrogate predict": (
        ["surrogate", "predict", "{tmp}/none", "{dataset}", "--constants", "{set}"],
        None,
    ),
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Inputs naming a packaged set: a tiny job and its dataset, a scene."""
    folder = tmp_path_factory.mktemp("inputs")
    job = job_dict(**{"job.samples_per_n": 4, "space.n_units": [2], "job.constants": PACKAGED})
    (folder / "job.toml").write_text(toml_text(job))
    assert main(["sweep", str(folder / "job.toml"), "--out", str(folder / "data")]) == 0
    scene = SCENE.replace("[scene]", f'[scene]\nconstants = "{PACKAGED}"', 1)
    (folder / "scene.toml").write_text(scene)
    return {
        "job": folder / "job.toml",
        "dataset": folder / "data",
        "scene": folder / "scene.toml",
        "tmp": folder,
    }


def _argv(command: str, value: str, inputs) -> list[str]:
    return [a.format(set=value, **inputs) for a in COMMANDS[command][0]]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_bad_set_is_one_line_naming_it(command, capsys, saved, inputs):
    capsys.readouterr()
    assert main(_argv(command, "nosuch", inputs)) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    # before it, only the warning that the job's or scene's packaged set failed validation
    *warnings, err = err.splitlines()
    assert all("FAILS validation" in line for line in warnings), warnings
    assert "--constants nosuch: no such constants set" in err or err.startswith(
        "dpfexplore identify: error: nosuch: no such constants set"
    ), err
    assert "packaged sets: paper, " + ", ".join(packaged_sets()) in err, err


@pytest.mark.parametrize("how", ["name", "path"])
@pytest.mark.parametrize(
    "command", sorted(c for c, (_, shows) in COMMANDS.items() if shows is not None)
)
def test_a_set_by_name_or_path_is_the_set(command, how, capsys, saved, inputs):
    capsys.readouterr()
    value = "mine" if how == "name" else str(saved)
    code = main(_argv(command, value, inputs))
    out, err = capsys.readouterr()
    shows = COMMANDS[command][1]
    if shows == "out":
        assert code == 0, err
        assert '"other' in out, out[:2000]  # "name": "other", or its "other:k_b" columns
    elif shows == "differs":
        argv = _argv(command, value, inputs)
        assert main(argv[: argv.index("--constants")]) == 0
        assert code == 0 and out != capsys.readouterr().out
    else:
        assert code == 2 and "'other'" in err and f"'{PACKAGED}'" in err, err
        assert "no such constants set" not in err


def test_a_toml_key_takes_a_name_too(saved, tmp_path):
    text = Path(GRIPPER).read_text().replace("[design]", '[design]\nconstants = "mine"', 1)
    (tmp_path / "finger.toml").write_text(text)
    assert load_design(tmp_path / "finger.toml").constants == other_set()
    named = text.replace('constants = "mine"', f'constants = "{packaged_sets()[0]}"')
    (tmp_path / "packaged.toml").write_text(named)
    assert load_design(tmp_path / "packaged.toml").constants.name == packaged_sets()[0]
