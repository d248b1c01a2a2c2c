"""The gripper scene's sorting objective: its table, the search, the re-verification, the figure.

The search and the re-verification run once (module fixture) on the shipped example scene with
a tiny budget, from the scene's reference gripper standing in for the scene's own design (whose
full optimisation is ``tests/inverse/test_inverse_design.py``'s slow test and would cost a
minute here): what is checked is what the sorting stage does with the design it is given.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from dpfexplore.cli import main
from dpfexplore.grasping import gripper_of, sort_objects
from dpfexplore.grasping.classes import class_margins
from dpfexplore.inverse.design import design_scene
from dpfexplore.inverse.engine.optimiser import ResidualRefinement
from dpfexplore.inverse.kinds import load_scene
from dpfexplore.inverse.scene_file import SceneSpecError
from dpfexplore.inverse.scenes.gripper import sorting_stage
from dpfexplore.inverse.scenes.gripper.report import write_gripper_report
from dpfexplore.inverse.scenes.gripper.solve import GripperTargetResult, gripper_problem
from dpfexplore.inverse.scenes.gripper.sorting_plot import plot_sorting_result
from dpfexplore.inverse.scenes.gripper.summary import summary_lines
from dpfexplore.io.toml_fields import read_toml
from dpfexplore.model.design import load_design

ROOT = Path(__file__).parents[2]
JOB = ROOT / "jobs" / "design-gripper-sorting.toml"


def tiny_text() -> str:
    """The example scene with a tiny budget: 4 margins, short fits, no window constraints."""
    text = JOB.read_text(encoding="utf-8")
    for old, new in (
        ("max_evaluations = 40", "max_evaluations = 4"),
        ("max_iter = 60", "max_iter = 30"),
        ("min_window_kPa = 10.0", "min_window_kPa = 0.0"),
        ("candidates_per_n = 256", "candidates_per_n = 8"),
        ("starts_per_n = 2", "starts_per_n = 1"),
    ):
        assert old in text, old
        text = text.replace(old, new)
    return text


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The sorting stage on the example, from the reference gripper; its report written."""
    tmp = tmp_path_factory.mktemp("sorting")
    path = tmp / "scene.toml"
    path.write_text(tiny_text(), encoding="utf-8")
    spec = load_scene(path)

    def reference_design(spec, index, evaluator):
        problem = gripper_problem(spec, evaluator)
        z = sorting_stage._reference_start(problem)[0]
        ev = problem.evaluate(z[None, :], purpose="refine", stiffness=True)
        best = ResidualRefinement(problem, z, ev, float(ev.objective[0]), 0, True)
        return GripperTargetResult(0, tuple(spec.kind_spec.apertures), best, True, {5: 0.0})

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sorting_stage, "solve_gripper", reference_design)
        outcome = design_scene(spec)
    out = tmp / "out"
    out.mkdir()
    write_gripper_report(spec, outcome.results, outcome.evaluator, out, wall_s=0.0)
    return spec, outcome, out


def test_search_is_at_least_the_default_and_the_report_reverifies(run, capsys):
    spec, outcome, out = run
    result = outcome.results[0]
    row = outcome.rows[0]["sorting"]
    s = result.sorting
    # the margin of the reported design (re-solved from its file) is never below the start's
    assert math.isfinite(s.default_margin)
    assert s.margins.margin >= s.default_margin - 1e-9
    assert row["search"]["evaluations"] <= 4
    # the written design file, read back: the same design, base and margins
    design = load_design(out / "gripper.toml")
    base = read_toml(out / "gripper.toml", "design")["result"]
    assert design.to_dict() == s.report.gripper.design.to_dict()
    gripper = gripper_of(design, base_L=base["base_L"], theta_B_deg=base["theta_B_deg"])
    again = class_margins(
        gripper, spec.kind_spec.sorting.classes, mu=0.5, tip_lasts=s.report.tip_lasts
    )
    assert again.margin == pytest.approx(row["margin"], abs=1e-12)
    # sort on the objects file the report wrote agrees with its confusion table
    report = sort_objects(gripper, out / "sorting-objects.csv", mu=0.5, lift_s=0.02)
    with open(out / "sorting-objects.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 4 * 15
    confusion: dict = {}
    for r, o in zip(rows, report.objects, strict=True):
        name = r["name"].split("-")[0]
        confusion.setdefault(name, {}).setdefault(o.label, 0)
        confusion[name][o.label] += 1
    assert confusion == row["confusion"]
    # and so does the command, on the written file alone (its base from the file's [result])
    capsys.readouterr()
    files = [str(out / "gripper.toml"), str(out / "sorting-objects.csv")]
    code = main(["sort", *files, "--lift-s", "0.02", "--json"])
    assert code == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["base_from"] == "gripper.toml [result]"
    assert [f"{o['size_state'] or 'none'}/{o['weight_class']}" for o in printed["objects"]] == [
        o.label for o in report.objects
    ]
    # met exactly when every class's samples got its own held outcome
    correct = {
        c["name"]: set(confusion[c["name"]]) == {c["label"]}
        and c["label"].split("/")[1] != "not_held"
        for c in row["classes"]
    }
    labels = [c["label"] for c in row["classes"]]
    assert row["met"] == (all(correct.values()) and len(set(labels)) == len(labels))
    assert result.met is (result.reachable and row["met"] and result.windows_ok is not False)
    # a class's margin is positive exactly when the re-verification sorted it
    for c in row["classes"]:
        if c["margin"] > 0:
            assert row["correct"][c["name"]]
    lines = "\n".join(summary_lines(spec, outcome.rows))
    assert "sorting: margin" in lines and "confusion" in lines and "70mm" in lines


def test_sorting_map_figure_draws_the_classes(run, monkeypatch):
    from matplotlib.patches import Rectangle
    from plotting.figure_checks import check_figure

    from dpfexplore.inverse.scenes.gripper import sorting_plot

    _, outcome, _ = run
    s = outcome.results[0].sorting
    monkeypatch.setattr(sorting_plot, "GRID", (40, 30))  # the figure's grid, not its content
    ax = plot_sorting_result(s)
    boxes = [
        p for p in ax.patches if isinstance(p, Rectangle) and p.get_label().startswith("class")
    ]
    assert sorted(p.get_label() for p in boxes) == sorted(f"class {c.name}" for c in s.classes)
    for p, c in zip(boxes, s.classes, strict=True):
        assert p.get_x() == pytest.approx(c.diameter[0])
        assert p.get_width() == pytest.approx(c.diameter[1] - c.diameter[0])
        assert p.get_y() == pytest.approx(1e3 * c.mass[0])
    crosses = [line for line in ax.lines if line.get_marker() == "x"]
    assert len(crosses[0].get_xdata()) == 60
    assert not check_figure(ax.figure)


BAD = [
    (
        '{name = "70mm", diameter = {min = 69.0, max = 71.0}',
        '{name = "70mm", diameter = {min = 60.5, max = 71.0}',
        "overlap",
    ),
    (
        '{name = "70mm", diameter = {min = 69.0, max = 71.0}',
        '{name = "70mm", diameter = {min = 69.0, max = 95.0}',
        "open gripper",
    ),
    (
        '{name = "35mm", diameter = {min = 34.0, max = 36.0}, mass = {min = 0.0001, max = 0.0003}}',
        '{name = "35mm", diameter = {min = 34.0, max = 36.0}, mass = -0.001}',
        "gripper.sorting.classes[3].mass = -0.001",
    ),
    ("mu = 0.5\nlift_s", "mu = -0.5\nlift_s", "gripper.sorting.mu"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_sorting_table_one_line(tmp_path, capsys, old, new, message):
    text = JOB.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "scene.toml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["design", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and message in err and "gripper.sorting" in err
    assert not out.exists()


def test_empty_classes_and_wrong_states(tmp_path):
    text = JOB.read_text(encoding="utf-8")
    start = text.index("classes = [")
    end = text.index("]\n", text.index("35mm")) + 2
    path = tmp_path / "scene.toml"
    path.write_text(text[:start] + "classes = []\n" + text[end:], encoding="utf-8")
    with pytest.raises(SceneSpecError, match=r"^gripper\.sorting\.classes = \[\]: need"):
        load_scene(path)
    path.write_text(
        text.replace(
            'states = ["10000", "11000", "11100", "11110"]', 'states = ["10000", "11000"]'
        ).replace("apertures = [70.0, 60.0, 45.0, 35.0]", "apertures = [70.0, 60.0]"),
        encoding="utf-8",
    )
    with pytest.raises(SceneSpecError, match=r"^gripper\.states = .*grasp states"):
        load_scene(path)


def test_scene_without_sorting_is_unchanged():
    spec = load_scene(ROOT / "jobs" / "design-gripper.toml")
    assert spec.kind_spec.sorting is None
    with_sorting = load_scene(JOB).kind_spec
    assert with_sorting.sorting is not None
    assert [c.name for c in with_sorting.sorting.classes] == ["70mm", "60mm", "45mm", "35mm"]
    # everything else of the [gripper] table reads the same as the plain scene's
    plain = spec.kind_spec
    for field in ("states", "apertures", "aperture_tol", "theta_B_deg", "base_L", "pulse_tau"):
        assert getattr(plain, field) == getattr(with_sorting, field)
    assert json.dumps(np.asarray(plain.apertures).tolist()) == "[70.0, 60.0, 45.0, 35.0]"
