"""Design validation: one bad value raises naming it; a batch gives the row a status instead."""

from __future__ import annotations

import numpy as np
import pytest

from dpfexplore.examples import example_path
from dpfexplore.model import status as st
from dpfexplore.model.design import MAX_UNITS, Design, DesignBatch, load_design

GOOD = dict(H=[4.0, 4.5, 5.0], U_L=8.0, U_sep=2.0, t=0.8, t_lim=1.5)


def test_scalars_broadcast_to_every_unit():
    d = Design(**GOOD)
    assert d.n_units == 3
    assert d.U_L == (8.0, 8.0, 8.0) and d.U_sep == (2.0, 2.0, 2.0)
    assert d.E == 26.0 and d.nu == 0.35 and d.r_b == 5.0 and d.t_ch == 1.0
    assert Design.from_dict(d.to_dict()) == d


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"H": [4.0, float("nan"), 5.0]}, "H[unit 2]"),
        ({"U_L": -1.0}, "U_L[unit 1]"),
        ({"U_sep": [2.0, 0.0, 2.0]}, "U_sep[unit 2]"),
        ({"U_sep": [2.0, 2.0]}, "U_sep"),
        ({"t": 0.0}, "t ="),
        ({"t_lim": float("inf")}, "t_lim"),
        ({"E": -26.0}, "E ="),
        ({"nu": 0.5}, "nu"),
        ({"H": []}, "N = 0"),
        ({"H": [4.0] * 13}, "N = 13"),
        ({"t": "thick"}, "t ="),
        ({"H": [0.5, 4.0, 4.0], "t": 1.0}, "k_b"),  # the closed form gives k_b < 0
        ({"H": [0.5, 4.0, 4.0], "t": 2.0}, "H[unit 1]"),
    ],
)
def test_a_bad_value_raises_naming_the_field(changes, field):
    with pytest.raises(ValueError) as info:
        Design(**{**GOOD, **changes})
    assert field in str(info.value)


def test_material_presets_and_toml(tmp_path):
    d = load_design(example_path("pickplace"))
    assert d.E == 26.0 and d.n_units == 6 and d.H[4] == 3.0
    g = load_design(example_path("gripper"))
    assert g.H == (3.8187, 4.1549, 4.5246, 4.8239, 2.5) and g.U_L == (8.5773,) * 5
    path = tmp_path / "ninja.toml"
    path.write_text(
        "[design]\nH = [4.0, 4.5]\nU_L = 7\nU_sep = 2\nt = 0.8\nt_lim = 1.2\n"
        'material = "ninjaflex-85a"\n'
    )
    assert load_design(path).E == 12.0


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ('H = [4.0]\nU_L = 7\nU_sep = 2\nt = 0.8\nt_lim = 1.2\ncolour = "red"', "colour"),
        ("H = [4.0]\nU_L = 7\nU_sep = 2\nt = 0.8", "t_lim: missing"),
        ('H = [4.0]\nU_L = 7\nU_sep = 2\nt = 0.8\nt_lim = 1.2\nmaterial = "steel"', "steel"),
        (
            'H = [4.0]\nU_L = 7\nU_sep = 2\nt = 0.8\nt_lim = 1.2\nmaterial = "cheetah-95a"\nE = 20',
            "not both",
        ),
    ],
)
def test_bad_toml_names_the_key(tmp_path, body, message):
    path = tmp_path / "d.toml"
    path.write_text("[design]\n" + body + "\n")
    with pytest.raises(ValueError, match=message):
        load_design(path)


def test_missing_table_and_broken_toml(tmp_path):
    path = tmp_path / "d.toml"
    path.write_text("[finger]\nH = [4.0]\n")
    with pytest.raises(ValueError, match=r"missing \[design\]"):
        load_design(path)
    path.write_text("[design\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_design(path)


def test_a_batch_flags_bad_rows_without_raising():
    good = Design(**GOOD)
    batch = DesignBatch.from_designs([good, good, good, good])
    H = batch.H.copy()
    H[1, 0] = np.nan
    H[3, 0] = 0.5
    t = batch.t.copy()
    t[3] = 1.0
    n_units = batch.n_units.copy()
    n_units[2] = MAX_UNITS + 1
    fields = {name: getattr(batch, name) for name in DesignBatch.ARRAY_FIELDS}
    bad = DesignBatch(**{**fields, "H": H, "t": t, "n_units": n_units})
    codes, messages = bad.problems()
    assert list(codes) == [st.OK, st.INVALID_INPUT, st.INVALID_INPUT, st.INVALID_CONSTANTS]
    assert messages[0] is None and "H[unit 1]" in messages[1] and "N = 13" in messages[2]
    assert "k_b" in messages[3]
    assert bad.design(0) == good
    with pytest.raises(ValueError):
        bad.design(1)


def test_a_batch_of_read_only_arrays_holds_writable_copies():
    # Arrays read back from Parquet are read-only, another array type for Numba: a batch holds
    # writable ones, so that the kernels compiled for sampled designs serve read-back ones too.
    fields = {
        name: getattr(DesignBatch.from_designs([Design(**GOOD)] * 3), name)
        for name in DesignBatch.ARRAY_FIELDS
    }
    for array in fields.values():
        array.setflags(write=False)
    batch = DesignBatch(**fields)
    for name in DesignBatch.ARRAY_FIELDS:
        assert getattr(batch, name).flags.writeable, name
        assert np.array_equal(getattr(batch, name), fields[name], equal_nan=True), name
    assert not fields["n_units"].flags.writeable  # the caller's arrays are left as they were
    writable = DesignBatch.from_designs([Design(**GOOD)])
    assert (
        DesignBatch(**{n: getattr(writable, n) for n in DesignBatch.ARRAY_FIELDS}).H is writable.H
    )
