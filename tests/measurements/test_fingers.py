"""Measurement files (issue 31 §1): the packaged data, the format's round trip, the refusals."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dpfexplore.measurements import (
    FORMAT,
    Measurement,
    MeasurementError,
    measurements_toml,
    packaged_measurements,
    read_measurements,
    write_measurements,
)
from dpfexplore.measurements.fingers import MAX_BYTES
from dpfexplore.model.design import Design

PAPER = Path(__file__).parents[2] / "dpfexplore" / "data" / "measurements" / "paper.toml"

# The paper's experimental_val tables, typed in again from the SI (target, model, experiments):
# the packaged file must hold these numbers, in this order.
NINJA = [
    ((46, 32), (46.85, 31.22), (42.9, 37.7)),
    ((25, 20), (25.34, 20.34), (23.53, 22.93)),
    ((25, 40), (30.10, 40.70), (29.4, 43.5)),
    ((25, 30), (28.76, 29.87), (23.0, 34.26)),
    ((35, 45), (37.98, 44.36), (36.8, 50.77)),
]
CHEETAH = [
    ((46, 32), (45.6, 31.8), (43.31, 28.38)),
    ((25, 20), (24.7, 19.5), (25.17, 16.55)),  # printed "25,17": a decimal comma
    ((25, 40), (25.15, 39.3), (23.03, 39.29)),
    ((25, 30), (25.2, 29.22), (22.9, 31.6)),
    ((35, 45), (33.97, 45.3), (33.35, 44.9)),
]


@pytest.fixture(scope="module")
def paper():
    return read_measurements(PAPER)


def test_the_paper_s_fingers_ship_with_the_package(paper):
    assert packaged_measurements() == [PAPER]
    names = [f.name for f in paper.fingers]
    assert len(names) == 13 and len(set(names)) == 13
    ninja = [f for f in paper.fingers if f.material == "ninjaflex-85a"]
    cheetah = [f for f in paper.fingers if f.material == "cheetah-95a" and f.tip is not None]
    stiff = [f for f in paper.fingers if f.stiffness is not None]
    for fingers, table in ((ninja, NINJA), (cheetah, CHEETAH)):
        assert len(fingers) == 5
        for f, (target, model, measured) in zip(fingers, table, strict=True):
            assert (f.target, f.reference_tip, f.tip) == (target, model, measured)
            assert f.state == "1" * f.design.n_units and f.stiffness is None
    assert [f.stiffness for f in stiff] == [0.55, 0.30, 0.15]
    assert [f.design.n_units for f in stiff] == [3, 4, 5]
    assert all(f.tip is None and f.material == "cheetah-95a" for f in stiff)
    assert {f.material_label for f in paper.fingers} == {"NinjaFlex 85A", "Cheetah 95A"}
    assert {f.design.E for f in ninja} == {12.0} and {f.design.E for f in cheetah} == {26.0}


def test_every_packaged_value_has_its_provenance(paper):
    for f in paper.fingers:
        given = {"design", "material", "state"} | {
            k for k in ("tip", "stiffness", "reference_tip", "target") if getattr(f, k) is not None
        }
        assert set(f.provenance) == given, f.name
        # a table or sentence of the paper, or MODEL.md's reading of it
        assert all(
            any(source in text for source in ("SI", "main text", "MODEL.md"))
            for text in f.provenance.values()
        )
    second = next(f for f in paper.fingers if f.name == "cheetah-target-2")
    assert "25,17" in second.provenance["tip"] and "25.17" in second.provenance["tip"]


def test_the_geometry_is_the_si_tables(paper):
    # spot checks of the three SI tables (heights unit 1 first, as printed)
    by_name = {f.name: f.design for f in paper.fingers}
    assert by_name["ninjaflex-target-5"].H == (4.35, 4.35, 4.72, 4.87, 4.95)
    assert by_name["ninjaflex-target-5"].U_sep == (1.01,) * 5
    assert by_name["cheetah-target-1"].U_L == (9.83,) * 4
    assert (by_name["cheetah-target-4"].t, by_name["cheetah-target-4"].t_lim) == (0.76, 1.07)
    assert by_name["cheetah-stiffness-5"].H == (4.9, 4.687, 4.57, 4.225, 4.2)


def test_the_paper_s_own_model_column_is_its_stated_distance(paper):
    # the reference column against the measured one, by hand from the SI numbers
    f = paper.fingers[0]
    assert math.hypot(46.85 - 42.9, 31.22 - 37.7) == pytest.approx(
        math.hypot(f.reference_tip[0] - f.tip[0], f.reference_tip[1] - f.tip[1])
    )


def test_the_packaged_file_round_trips(paper, tmp_path):
    written = write_measurements(
        tmp_path / "again.toml", paper.fingers, title=paper.title, source=paper.source
    )
    assert written.fingers == paper.fingers
    assert (written.title, written.source) == (paper.title, paper.source)
    assert read_measurements(tmp_path / "again.toml").fingers == paper.fingers


def _finger(**changes):
    values = {
        "name": "lab-1",
        "design": Design(H=[4.5, 4.2, 4.0], U_L=7.0, U_sep=[1.0, 1.1, 1.2], t=0.8, t_lim=1.3),
        "state": "101",
        "material": "cheetah-95a",
        "tip": (30.5, 12.25),
        "provenance": {"tip": "our bench, 2026-03-02"},
    }
    values.update(changes)
    return Measurement(**values)


def test_every_field_round_trips(tmp_path):
    fingers = [
        _finger(),
        _finger(
            name='odd "name" \\ é \x7f 😀',
            material="my TPU",
            design=Design(
                H=[4.0, 3.5], U_L=[7.0, 7.5], U_sep=1.0, t=0.7, t_lim=1.2, E=17.5, r_b=5.5
            ),
            state="11",
            tip=None,
            stiffness=0.25,
            stiffness_uncertainty=0.02,
            provenance={"": "one source for all"},
        ),
        _finger(
            name="lab-3", tip_uncertainty=(0.3, 0.4), reference_tip=(31.0, 12.0), target=(30, 12)
        ),
        _finger(name="lab-4", material=None, design=_finger().design.replace(E=30.0, nu=0.4)),
    ]
    written = write_measurements(tmp_path / "lab.toml", fingers, title="lab prints")
    assert written.fingers == tuple(fingers)
    assert written.fingers[1].material_label == "my TPU"
    assert written.fingers[3].material_label == "E = 30 MPa"


@settings(max_examples=40, deadline=None)
@given(
    name=st.text(min_size=1).filter(lambda s: s.strip()),
    x=st.floats(-80, 80, allow_nan=False),
    y=st.floats(-80, 80, allow_nan=False),
    k=st.floats(1e-6, 1e3),
)
def test_names_and_numbers_round_trip(tmp_path_factory, name, x, y, k):
    finger = _finger(name=name, tip=(x, y), stiffness=k, provenance={"": name})
    path = tmp_path_factory.mktemp("rt") / "f.toml"
    assert write_measurements(path, [finger]).fingers == (finger,)


# ----------------------------------------------------------------------------- refusals

GOOD = """format = "dpfexplore-measurements/1"

[[finger]]
name = "a"
material = "ninjaflex-85a"
H = [4.5, 4.7, 4.8]
U_sep = 1.0
U_L = 7.0
t = 0.6
t_lim = 1.5
state = "111"
tip = [30.0, 20.0]
provenance = "bench"

[[finger]]
name = "b"
material = "cheetah-95a"
H = [4.5, 4.2]
U_sep = 1.0
U_L = 7.0
t = 0.8
t_lim = 1.2
state = "11"
stiffness = 0.3
provenance = "bench"
"""


def _refused(tmp_path, text, *needles):
    path = tmp_path / "m.toml"
    path.write_text(text)
    with pytest.raises(MeasurementError) as info:
        read_measurements(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)), message
    for needle in needles:
        assert needle in message, message
    return message


def test_a_good_file_reads(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(GOOD)
    file = read_measurements(path)
    assert [f.name for f in file.fingers] == ["a", "b"] and file.sha256


@pytest.mark.parametrize(
    ("old", "new", "needles"),
    [
        ("t_lim = 1.5\n", "", ["finger 1 ('a')", "t_lim", "missing"]),
        (
            'material = "ninjaflex-85a"',
            'material = "ninjaflex-95a"',
            ["finger 1", "material", "unknown material"],
        ),
        ('material = "cheetah-95a"\n', "", ["finger 2 ('b')", "material", "missing"]),
        ("tip = [30.0, 20.0]", "tip = [30.0, nan]", ["finger 1", "tip", "not a finite number"]),
        ("t = 0.6", "t = inf", ["finger 1", "t = inf", "not a finite number"]),
        ("H = [4.5, 4.2]", "H = [4.5, nan]", ["finger 2", "H", "not a finite number"]),
        ('state = "111"', 'state = "11"', ["finger 1", "state = '11'", "3 characters"]),
        ('state = "11"\n', 'state = "1x"\n', ["finger 2", "state", "2 characters 0/1"]),
        ('state = "111"', "state = 111", ["finger 1", "state = 111"]),
        ('state = "111"\n', "", ["finger 1", "state", "missing"]),
        ("tip = [30.0, 20.0]\n", "", ["finger 1", "tip", "the stiffness or both"]),
        ("stiffness = 0.3", "stiffness = -0.3", ["finger 2", "stiffness", "> 0"]),
        ('name = "b"', 'name = "a"', ["finger 2 ('a')", "name", "used by an earlier finger"]),
        (
            'provenance = "bench"\n\n[[finger]]',
            "\n[[finger]]",
            ["finger 1", "provenance", "missing"],
        ),
        ("t = 0.6", "t = 0.6\ncolour = 1", ["finger 1", "colour", "unknown key"]),
        ("H = [4.5, 4.7, 4.8]", "H = [4.5, 4.7, 7.5]", ["finger 1", "H[unit 3]"]),
        ('format = "dpfexplore-measurements/1"', 'format = "x/2"', ["format = 'x/2'"]),
        ('format = "dpfexplore-measurements/1"\n', "", ["format: missing"]),
        (
            'format = "dpfexplore-measurements/1"',
            'format = "dpfexplore-measurements/1"\n[fingers]',
            ["fingers: unknown key"],
        ),
        (
            "tip = [30.0, 20.0]",
            "tip = [30.0, 20.0]\ntip_uncertainty = -1",
            ["tip_uncertainty", ">= 0"],
        ),
        (
            "stiffness = 0.3",
            "tip = [1.0, 2.0]\nstiffness_uncertainty = 0.1",
            ["stiffness_uncertainty", "without stiffness"],
        ),
        ("U_L = 7.0", "U_L = [7.0, 7.0]", ["finger 1", "U_L", "3 units"]),
    ],
)
def test_bad_input_is_one_line_naming_file_finger_and_key(tmp_path, old, new, needles):
    assert old in GOOD
    _refused(tmp_path, GOOD.replace(old, new, 1), *needles)


def test_not_toml_and_no_fingers(tmp_path):
    _refused(tmp_path, "format = \n", "not valid TOML")
    _refused(tmp_path, f'format = "{FORMAT}"\n', "no [[finger]] tables")
    path = tmp_path / "bin.toml"
    path.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(MeasurementError, match="not a text file"):
        read_measurements(path)


def test_reads_are_bounded(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text(GOOD + "#" * MAX_BYTES)
    with pytest.raises(MeasurementError, match="more than the limit"):
        read_measurements(big)
    with pytest.raises(MeasurementError, match="is a directory"):
        read_measurements(tmp_path)
    with pytest.raises(MeasurementError, match="no such measurement file"):
        read_measurements(tmp_path / "missing.toml")
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)  # nobody writes: a reader that opened it would block
    with pytest.raises(MeasurementError, match="not a regular file"):
        read_measurements(fifo)
    with pytest.raises(MeasurementError, match="not a regular file"):
        read_measurements("/dev/zero")


def test_a_design_file_instead_of_inline_keys(tmp_path):
    (tmp_path / "prints").mkdir()
    (tmp_path / "prints" / "a.toml").write_text(
        '[design]\nmaterial = "ninjaflex-85a"\nH = [4.5, 4.7, 4.8]\nU_sep = 1.0\nU_L = 7.0\n'
        "t = 0.6\nt_lim = 1.5\n"
    )
    inline = GOOD.split("[[finger]]")[1]
    by_file = inline.replace(
        'material = "ninjaflex-85a"\nH = [4.5, 4.7, 4.8]\nU_sep = 1.0\nU_L = 7.0\nt = 0.6\n'
        "t_lim = 1.5\n",
        'design = "prints/a.toml"\n',
    )
    path = tmp_path / "m.toml"
    path.write_text(f'format = "{FORMAT}"\n[[finger]]{by_file}')
    first = read_measurements(path).fingers[0]
    path.write_text(f'format = "{FORMAT}"\n[[finger]]{inline}')
    assert first == read_measurements(path).fingers[0]
    assert first.material == "ninjaflex-85a"
    # both at once, a missing design file, one naming a constants set: refused
    _refused(tmp_path, f'format = "{FORMAT}"\n[[finger]]{by_file}t = 0.6\n', "not both")
    _refused(
        tmp_path,
        f'format = "{FORMAT}"\n[[finger]]{by_file.replace("a.toml", "b.toml")}',
        "design",
        "no such design file",
    )
    (tmp_path / "prints" / "a.toml").write_text(
        (tmp_path / "prints" / "a.toml").read_text() + 'constants = "x.json"\n'
    )
    _refused(tmp_path, f'format = "{FORMAT}"\n[[finger]]{by_file}', "constants", "not taken here")


def test_nothing_is_returned_in_part(tmp_path):
    # the second finger is bad: no fingers at all come back
    _refused(tmp_path, GOOD.replace('state = "11"', 'state = "111"'), "finger 2")


def test_measurements_toml_writes_the_format_line_first():
    text = measurements_toml([_finger()])
    assert text.splitlines()[0] == f'format = "{FORMAT}"'
