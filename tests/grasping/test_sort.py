"""The sorting loop: the parallel kernel against the per-object loop, the map, CLI, bad files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from plotting.figure_checks import assert_readable

from dpfexplore._kernels.grasp import batch as kb
from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.grasping import GraspOptions, grasp, gripper_of
from dpfexplore.grasping.grasp import deciding_state
from dpfexplore.grasping.setup import GRAVITY
from dpfexplore.grasping.sort import run_sort, sorting_map
from dpfexplore.model.design import load_design

#: Between the apertures (77.1, 60.0, 44.9, 35.0 mm), inside the smallest, beyond the open
#: gripper's tips, and 70 mm (the paper's object, which pushes 11000's domes back).
DIAMETERS = np.array([30.0, 38.0, 47.0, 65.0, 70.0, 80.0])
MASSES = np.array([0.001, 0.0069, 0.003, 0.2, 0.001, 0.004])

CSV = """name,diameter,mass,class
a,38,0.001,11110/light
b,47,0.003,11100/light
c,47,0.0065,11100/heavy
d,30,0.001,none/not_held
e,65,0.5,11000
"""


@pytest.fixture(scope="module")
def gripper():
    return gripper_of(load_design(example_path("gripper")))


def _loop(gripper, diameter, mass, mu):
    """The paper's loop on :func:`grasp`'s per-state records (the Python reference)."""
    report = grasp(gripper, float(diameter), float(mass), mu=mu)
    size = deciding_state(report.states)
    if size is None:
        return -1, np.nan, np.nan, "not_held"
    j = gripper.states.index(size)
    pay, tip = report.states[j].payload_N, report.tip_states[j].payload_N
    weight = mass * GRAVITY
    if pay >= weight:  # held: the tip unit is never inverted
        return j, pay, np.nan, "light"
    return j, pay, tip, "heavy" if tip >= weight else "not_held"


def test_parallel_kernel_agrees_with_the_per_object_loop_exactly(gripper):
    mu = 0.5
    table = run_sort(
        gripper,
        DIAMETERS,
        MASSES * GRAVITY,
        mu=mu,
        depth=gripper.default_depth(),
        threshold=gripper.threshold(0.1),
        tip_lasts=True,
        options=GraspOptions(),
    )
    classes = ("light", "heavy", "not_held")
    for row, d, m in zip(table, DIAMETERS, MASSES, strict=True):
        j, pay, tip, cls = _loop(gripper, d, m, mu)
        assert int(row[kb.S_SIZE]) == j
        assert classes[int(row[kb.S_WEIGHT])] == cls
        np.testing.assert_array_equal(row[[kb.S_PAYLOAD, kb.S_PAYLOAD_TIP]], [pay, tip])
    # the classes the issue asks for: sizes by the first smaller aperture, each weight class
    assert list(table[:, kb.S_SIZE].astype(int)) == [-1, 3, 2, 1, 1, 0]
    assert {classes[int(c)] for c in table[:, kb.S_WEIGHT]} == set(classes)


def test_sorting_map_is_the_loop_at_every_grid_point(gripper):
    diameters = np.array([38.0, 47.0, 65.0])
    masses = np.array([0.0, 0.004, 0.0065, 0.05])
    size, weight = sorting_map(gripper, diameters, masses, mu=0.5)
    d, m = np.meshgrid(diameters, masses)
    table = run_sort(
        gripper,
        d.ravel(),
        m.ravel() * GRAVITY,
        mu=0.5,
        depth=gripper.default_depth(),
        threshold=gripper.threshold(0.1),
        tip_lasts=True,
        options=GraspOptions(),
    )
    np.testing.assert_array_equal(size.ravel(), table[:, kb.S_SIZE].astype(int))
    np.testing.assert_array_equal(weight.ravel(), table[:, kb.S_WEIGHT].astype(int))


def _refuse(name):
    raise ValueError(f"non-strict JSON constant {name}")


@pytest.fixture(scope="module")
def sorted_json(tmp_path_factory):
    import contextlib
    import io

    path = tmp_path_factory.mktemp("sort") / "objects.csv"
    path.write_text(CSV)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["sort", "gripper", str(path), "--json", "--lift-s", "0.02"])
    return code, json.loads(out.getvalue(), parse_constant=_refuse)


def test_sort_json_has_classes_confusion_and_accuracy(sorted_json):
    code, doc = sorted_json
    assert code == 0
    objects = doc["objects"]
    assert [o["name"] for o in objects] == list("abcde")
    for o in objects:
        assert {"name", "diameter", "mass", "size_state", "weight_class"} <= set(o)
    assert objects[3]["size_state"] is None and objects[3]["weight_class"] == "not_held"
    # accuracy and confusion recomputed from the objects' outcomes
    right = 0
    counts: dict = {}
    for o in objects:
        label = f"{o['size_state'] or 'none'}/{o['weight_class']}"
        true = o["true_class"]
        right += true == label if "/" in true else true == (o["size_state"] or "none")
        counts.setdefault(true, {}).setdefault(label, 0)
        counts[true][label] += 1
    assert doc["accuracy"] == right / len(objects)
    assert doc["confusion"] == counts
    assert doc["tip_lasts"] == (doc["tip_reset_s"] >= 0.02)


def test_sort_plot_draws_the_map_boundaries_and_objects(gripper):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import QuadMesh

    from dpfexplore.grasping.sort import WEIGHT_CLASSES
    from dpfexplore.plotting.grasp import plot_sorting_map

    diameters = np.linspace(30.0, 80.0, 12)
    masses = np.linspace(0.0, 0.01, 5)
    size, weight = sorting_map(gripper, diameters, masses, mu=0.5)
    ax = plot_sorting_map(
        diameters,
        masses,
        size,
        weight,
        states=gripper.states,
        weight_classes=WEIGHT_CLASSES,
        objects=(DIAMETERS, MASSES),
        ax=plt.figure(figsize=(6, 4), dpi=40).add_subplot(),
    )
    assert len([c for c in ax.collections if isinstance(c, QuadMesh)]) == 1
    assert len(ax.collections) >= 2  # the map and at least one boundary
    crosses = [line for line in ax.lines if line.get_marker() == "x"]
    assert len(crosses) == 1 and len(crosses[0].get_xdata()) == DIAMETERS.size
    labels = {t.get_text() for t in ax.get_legend().get_texts()}
    assert "objects" in labels and "none/not_held" in labels
    assert "mm" in ax.get_xlabel() and "g" in ax.get_ylabel()
    ax.figure.canvas.draw()
    inside, box = ax.get_window_extent(), ax.get_legend().get_window_extent()
    assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 <= inside.y1
    assert_readable(ax.figure)
    plt.close(ax.figure)


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("name,diameter\na,40\n", "no column 'mass'"),
        ("name,diameter,mass\na,40,0.01\nb,nan,0.01\n", "row 2 (line 3), column 'diameter'"),
        ("name,diameter,mass\na,40,-0.01\n", "row 1 (line 2), column 'mass': '-0.01' is negative"),
        ("name,diameter,mass\na,40\n", "row 1 (line 2), column 'mass': missing"),
    ],
)
def test_bad_objects_file_is_one_line_naming_file_row_and_column(
    text, named, tmp_path, capsys, monkeypatch
):
    import importlib

    api = importlib.import_module("dpfexplore.grasping.sort")

    def refuse(*args, **kwargs):
        raise AssertionError("sorted a refused file")

    monkeypatch.setattr(api, "sort_objects", refuse)
    path = tmp_path / "objects.csv"
    path.write_text(text)
    assert main(["sort", "gripper", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and named in lines[0]
