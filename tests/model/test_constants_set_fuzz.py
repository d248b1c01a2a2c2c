"""Random mutations of a valid constants set file: refused in one line naming it, or the same set.

A mutation deletes a field, retypes it, puts NaN, infinities, huge, negative or zero numbers or a
deep nesting in its place, or flips, drops or inserts bytes of the file. Mutations of the
contents are tried both with the stale fingerprint (refused, unless the document means the same
set) and with one made to match (so that they reach the checks behind it): a mutated file
either is refused in one line that names it, or loads as the unmutated set (same fingerprint,
same numbers), or, with a matching fingerprint, as another set whose claims hold: its forms
finite and physical over its domain.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dpfexplore.model.constants_set import (
    ClosedForm,
    ConstantsSet,
    ConstantsSetError,
    _fingerprint,
    load_constants_set,
)

#: A small valid set: one or two terms per form, a dimensionless domain and a hull.
SMALL = ConstantsSet(
    name="small",
    k_hat=ClosedForm(((0, 0), (1, 1)), (4.0, 0.5)),
    alpha=ClosedForm(((0, 0), (1, 0)), (0.05, 0.1)),
    tip_ratio=ClosedForm(((0, 0), (1, -1)), (2.0, 0.05)),
    domain={"H_over_rb": (0.6, 1.0), "t_over_rb": (0.1, 0.2), "E": (5.0, 40.0), "nu": (0.3, 0.49)},
    provenance={"made by": "tests/model/test_constants_set_fuzz.py", "seed": 3},
    hull=((0.6, 0.1), (1.0, 0.1), (1.0, 0.2), (0.6, 0.2)),
)
DOCUMENT = SMALL.to_dict()
TEXT = json.dumps(DOCUMENT, indent=1, sort_keys=True)
DEEP = "__deep__"  # stands for 200,000 nested lists, spliced into the text
#: Domes (H/r_b, t/r_b) inside the small set's domain, at r_b = 5 mm, E = 26 MPa.
H = 5.0 * np.array([0.6, 0.8, 1.0, 0.7])
T = 5.0 * np.array([0.1, 0.15, 0.2, 0.18])

REPLACEMENTS = st.sampled_from(
    [
        None,
        True,
        "text",
        "",
        [],
        {},
        [[[[1.0]]]],
        math.nan,
        math.inf,
        -math.inf,
        1e300,
        -1e300,
        10**400,
        -(10**30),
        -1.0,
        -1,
        0,
        0.0,
        1e-300,
        0.5,
        7,
        DEEP,
    ]
)


def _paths(value, prefix=()):
    """Every path to a value in a JSON document (the root excluded)."""
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return
    for key, child in items:
        yield (*prefix, key)
        yield from _paths(child, (*prefix, key))


PATHS = list(_paths(DOCUMENT))


def _mutated(document, path, action, replacement):
    """``document`` with the value at ``path`` deleted, replaced, scaled or negated."""
    data = copy.deepcopy(document)
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    if action == "delete":
        del parent[key]
    elif action == "negate" and isinstance(parent[key], int | float):
        parent[key] = -parent[key]
    elif action == "scale" and isinstance(parent[key], int | float):
        parent[key] = parent[key] * 1e3
    elif action == "wrap":
        parent[key] = [parent[key]]
    else:
        parent[key] = replacement
    return data


def _text(data, refingerprint):
    if refingerprint:
        body = {k: v for k, v in data.items() if k not in ("fingerprint", "validation")}
        try:
            data = {**data, "fingerprint": _fingerprint(body)}
        except (TypeError, ValueError):  # NaN or the deep stand-in: keep the stale one
            pass
    text = json.dumps(data, indent=1, sort_keys=True)  # NaN and Infinity as JavaScript has them
    return text.replace(f'"{DEEP}"', "[" * 200_000 + "]" * 200_000)


def _check(path: Path, *, same_fingerprint: bool) -> None:
    try:
        loaded = load_constants_set(path)
    except ConstantsSetError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{path}: "), message
        return
    unmutated = SMALL.evaluate(H, T, 5.0, 26.0)
    values = loaded.evaluate(H, T, 5.0, 26.0)
    if loaded.fingerprint == SMALL.fingerprint or same_fingerprint:
        assert loaded.fingerprint == SMALL.fingerprint
        for name, value in unmutated.items():
            np.testing.assert_array_equal(values[name], value)
        return
    # another set, with a fingerprint of its own: its claims hold where it claims them
    inside = loaded.in_domain(H, T, 5.0, 26.0, 0.35)
    h = np.linspace(*loaded.ratio_ranges()[0], 9)
    s = np.linspace(*loaded.ratio_ranges()[1], 9)
    grid_h, grid_s = np.meshgrid(h, s)
    claimed = loaded.inside_hull(grid_h, grid_s)
    for form in (values, loaded.evaluate(grid_h, grid_s, 1.0, 1.0)):
        assert all(np.all(np.isfinite(v)) for v in form.values())
    grid = loaded.evaluate(grid_h, grid_s, 1.0, 1.0)
    assert np.all(grid["k_b"][claimed] > 0) and np.all(grid["tip_dis"][claimed] > grid_h[claimed])
    assert np.all((grid["alpha"][claimed] > 0) & (grid["alpha"][claimed] < 1))
    assert np.all(values["k_b"][inside] > 0)


@settings(max_examples=120)
@given(
    index=st.integers(0, len(PATHS) - 1),
    action=st.sampled_from(["delete", "replace", "negate", "scale", "wrap"]),
    replacement=REPLACEMENTS,
    refingerprint=st.booleans(),
)
def test_a_mutated_field_is_refused_in_one_line_or_changes_nothing(
    tmp_path_factory, index, action, replacement, refingerprint
):
    path = tmp_path_factory.mktemp("fields") / "set.json"
    data = _mutated(DOCUMENT, PATHS[index], action, replacement)
    path.write_text(_text(data, refingerprint))
    _check(path, same_fingerprint=not refingerprint)


@settings(max_examples=80)
@given(
    edits=st.lists(
        st.tuples(
            st.sampled_from(["flip", "drop", "insert", "truncate"]),
            st.integers(0, len(TEXT) - 1),
            st.integers(1, 255),
        ),
        min_size=1,
        max_size=3,
    )
)
def test_flipped_dropped_or_inserted_bytes_are_refused_in_one_line_or_change_nothing(
    tmp_path_factory, edits
):
    raw = bytearray(TEXT.encode())
    for kind, at, byte in edits:
        at = min(at, len(raw) - 1)
        if kind == "flip":
            raw[at] ^= byte
        elif kind == "drop":
            del raw[at]
        elif kind == "insert":
            raw.insert(at, byte)
        else:
            del raw[at:]
        if not raw:
            break
    path = tmp_path_factory.mktemp("bytes") / "set.json"
    path.write_bytes(bytes(raw))
    _check(path, same_fingerprint=True)


def test_the_unmutated_file_loads_as_the_small_set(tmp_path):
    path = tmp_path / "set.json"
    path.write_text(TEXT)
    assert load_constants_set(path) == SMALL
    _check(path, same_fingerprint=True)
