"""A constants set's claims proven over its whole domain, and its file read within bounds.

The physical check bounds each closed form on the domain (Bernstein enclosures), so a set
unphysical anywhere in it is refused, however narrow the place; the hull must hold the points
its ranges claim; magnitudes are bounded. Every malformed file is refused in one line naming it.
"""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dpfexplore.cli import main
from dpfexplore.model.constants_set import (
    DEFAULT,
    PACKAGED_DIR,
    ClosedForm,
    ConstantsSet,
    ConstantsSetError,
    _fingerprint,
    find_constants_set,
    load_constants_set,
    packaged_sets,
)
from dpfexplore.model.quantities import SET_FORMS, scaled
from dpfexplore.model.set_checks.bounds import Bound, _polynomials, _proven, first_violation
from dpfexplore.model.set_checks.claims import FORM_BOUNDS
from dpfexplore.model.set_checks.fields import MAX_SET_BYTES

ROOT = Path(__file__).parents[2]
GRIPPER = str(ROOT / "dpfexplore" / "examples" / "gripper.toml")
BOX = {"H_over_rb": [0.6, 1.0], "t_over_rb": [0.1, 0.2], "E": [5.0, 40.0]}


def write_set(path: Path, data: dict, *, refingerprint: bool = True) -> Path:
    """``data`` as a set file, its fingerprint made to match unless told otherwise."""
    data = copy.deepcopy(data)
    if refingerprint:
        body = {k: v for k, v in data.items() if k not in ("fingerprint", "validation")}
        data["fingerprint"] = _fingerprint(body)
    path.write_text(json.dumps(data))
    return path


def refused(path: Path, *needles: str) -> str:
    """Load ``path``; it must be refused in one line that names it and says ``needles``."""
    with pytest.raises(ConstantsSetError) as info:
        load_constants_set(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)), message
    for needle in needles:
        assert needle in message, message
    return message


def cli_refused(capsys, path: str, *needles: str) -> str:
    """``states gripper --constants PATH`` exits 2 with one line naming the file."""
    assert main(["states", GRIPPER, "--sequential", "--constants", path]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert captured.out == "" and "\n" not in err and "Traceback" not in err, err
    assert f"--constants {path}: " in err, err
    for needle in needles:
        assert needle in err, err
    return err


def paper_data() -> dict:
    return DEFAULT.to_dict()


# --------------------------------------------------------------------------- the physical check


def test_a_set_negative_between_the_old_grid_points_is_refused(tmp_path):
    # k_hat = (π3 − p)² − 1e-8: negative only where π3 is within 1e-4 of p, which sits halfway
    # between the first two columns of a 41 × 41 grid over H/r_b 0.6-1
    h_star = 0.6 + 0.4 * 0.5 / 40
    p = 2 * h_star**2 / (h_star**2 + 1)
    data = paper_data()
    data["domain"] = BOX
    data["k_hat"] = {
        "terms": [
            {"pi1": 0, "pi3": 0, "coefficient": p * p - 1e-8},
            {"pi1": 0, "pi3": 1, "coefficient": -2 * p},
            {"pi1": 0, "pi3": 2, "coefficient": 1.0},
        ]
    }
    path = write_set(tmp_path / "between.json", data)
    grid_h, grid_s = np.meshgrid(np.linspace(0.6, 1.0, 41), np.linspace(0.1, 0.2, 41))
    form = ClosedForm(((0, 0), (0, 1), (0, 2)), (p * p - 1e-8, -2 * p, 1.0))
    on_grid = form(grid_s / grid_h, 2 * grid_h**2 / (grid_h**2 + 1))
    assert on_grid.min() > 0  # the grid would have passed it
    assert form(0.1 / h_star, p) < 0  # and it is negative at h_star
    message = refused(path, "k_b <= 0 inside its own domain, at H/r_b = 0.605")
    assert message.endswith("t/r_b = 0.1")


def test_a_tiny_hull_between_grid_points_does_not_disable_the_check(tmp_path):
    data = paper_data()
    data["domain"] = {"H_over_rb": [0.6, 1.0], "t_over_rb": [0.1, 0.2]}
    data["k_hat"] = {"terms": [{"pi1": 0, "pi3": 0, "coefficient": -1.0}]}  # k_hat = −1
    x, y = 0.605, 0.10125
    data["hull"] = [[x, y], [x + 1e-4, y], [x, y + 1e-4]]
    refused(
        write_set(tmp_path / "tiny.json", data),
        "the hull spans H/r_b 0.605-0.6051, t/r_b 0.1013-0.1014, not its ranges (H/r_b 0.6-1, "
        "t/r_b 0.1-0.2)",
    )
    # with ranges from H, t and r_b (which a hull need not reach) the hull is too small
    data["domain"] = {"H": [3.0, 5.0], "t": [0.5, 1.0], "r_b": [5.0, 5.0]}
    refused(
        write_set(tmp_path / "tiny-mm.json", data),
        "the hull covers 1.3e-07 of the box of its ranges, less than 0.001",
    )
    # and a hull of honest size proves k_hat = −1 negative
    data["hull"] = [[0.6, 0.1], [1.0, 0.1], [0.6, 0.2]]
    refused(write_set(tmp_path / "hull.json", data), "k_b <= 0 inside its own domain, at")


def test_a_hull_must_be_convex_counter_clockwise_and_inside_its_ranges(tmp_path):
    data = paper_data()
    data["domain"] = BOX | {"H_over_rb": [0.6, 1.0], "t_over_rb": [0.1, 0.2]}
    triangle = [[0.6, 0.1], [1.0, 0.1], [0.6, 0.2]]
    data["hull"] = triangle[::-1]
    refused(write_set(tmp_path / "cw.json", data), "not a convex polygon")
    data["hull"] = [[0.6, 0.1], [1.0, 0.1], [0.7, 0.12], [1.0, 0.2], [0.6, 0.2]]  # a dent
    refused(write_set(tmp_path / "dent.json", data), "not a convex polygon")
    data["hull"] = [[0.6, 0.1], [1.2, 0.1], [0.6, 0.2]]
    refused(write_set(tmp_path / "out.json", data), "beyond its ranges")
    data["hull"] = triangle
    assert load_constants_set(write_set(tmp_path / "ok.json", data)).hull == tuple(
        map(tuple, triangle)
    )


def test_coefficients_and_values_beyond_a_physical_set_are_refused(tmp_path, capsys):
    data = paper_data()
    data["k_hat"]["terms"][0]["coefficient"] = 1e300
    path = write_set(tmp_path / "huge.json", data)
    refused(path, "k_hat.terms[0].coefficient: must be a number within ±1e+06")
    cli_refused(capsys, str(path), "within ±1e+06")
    # within the coefficient limit but k_hat far above anything a dome has
    data = paper_data()
    data["k_hat"]["terms"][0]["coefficient"] = 5e5
    refused(write_set(tmp_path / "stiff.json", data), "k_hat >= 10000 inside its own domain")
    data = paper_data()
    data["tip_ratio"] = {"terms": [{"pi1": 0, "pi3": 0, "coefficient": 150.0}]}
    refused(write_set(tmp_path / "tip.json", data), "tip_ratio >= 100 inside its own domain")
    data["tip_ratio"] = {"terms": [{"pi1": 0, "pi3": 0, "coefficient": 0.9}]}
    refused(write_set(tmp_path / "short.json", data), "tip_dis <= H")
    data = paper_data()
    data["alpha"] = {  # alpha = 0.9 + 0.7 π1: above 1 for t/H > 1/7
        "terms": [
            {"pi1": 0, "pi3": 0, "coefficient": 0.9},
            {"pi1": 1, "pi3": 0, "coefficient": 0.7},
        ]
    }
    refused(write_set(tmp_path / "alpha.json", data), "alpha outside (0, 1) inside its own")
    # the API refuses the same set (identification calls check())
    with pytest.raises(ConstantsSetError, match="constants set 'paper': k_hat has a coefficient"):
        ConstantsSet(
            name="paper",
            k_hat=ClosedForm(((0, 0),), (1e300,)),
            alpha=DEFAULT.alpha,
            tip_ratio=DEFAULT.tip_ratio,
            domain=dict(DEFAULT.domain),
        ).check()


def test_a_form_touching_its_bound_is_not_proven(tmp_path):
    # k_hat = (π1 − 0.15)² is zero along t/H = 0.15 (k_b = 0 is no spring); a double root
    # leaves Bernstein bounds open to the last depth, or a point lands on it
    data = paper_data()
    data["domain"] = BOX
    data["k_hat"] = {
        "terms": [
            {"pi1": 0, "pi3": 0, "coefficient": 0.0225},
            {"pi1": 1, "pi3": 0, "coefficient": -0.3},
            {"pi1": 2, "pi3": 0, "coefficient": 1.0},
        ]
    }
    message = refused(write_set(tmp_path / "touch.json", data), "k_b <= 0")
    assert "inside its own domain" in message


def test_the_form_bounds_are_the_physical_conditions_of_the_forms():
    assert list(FORM_BOUNDS) == [form.name for form in SET_FORMS]
    H, t, R, E = 4.0, 0.8, 5.125, 26.0
    for form in SET_FORMS:
        low, _ = FORM_BOUNDS[form.name]
        quantity = [scaled(form.scale, v, H, t, R, E) for v in (low, np.nextafter(low, 2))]
        assert not form.physical(quantity[0], H) and form.physical(quantity[1], H), form.name
    alpha = next(form for form in SET_FORMS if form.name == "alpha")
    assert not alpha.physical(FORM_BOUNDS["alpha"][1], H)


def test_every_packaged_set_is_proven_and_unchanged():
    assert packaged_sets() == ["shell-extended"]
    path = PACKAGED_DIR / "shell-extended.json"
    constants = load_constants_set(path)
    assert constants.fingerprint == json.loads(path.read_text())["fingerprint"]
    assert constants.fingerprint.startswith("5377b07003cb")
    constants.check()
    DEFAULT.check()


# --------------------------------------------------------------------------- Bernstein bounds


@settings(max_examples=40)
@given(
    terms=st.lists(
        st.tuples(st.integers(-6, 6), st.integers(-6, 6), st.floats(-10, 10)),
        min_size=1,
        max_size=4,
        unique_by=lambda t: t[:2],
    ),
    h0=st.floats(0.05, 1.5),
    s0=st.floats(0.02, 0.3),
    width=st.tuples(st.floats(1e-3, 0.5), st.floats(1e-3, 0.2)),
    upper=st.booleans(),
)
def test_a_proof_holds_at_every_point_and_a_refutation_is_real(terms, h0, s0, width, upper):
    # soundness both ways: a bound proven over the box holds on a fine grid of it, and a
    # counterexample breaks the bound where it is said to
    exponents = tuple((p, q) for p, q, _ in terms)
    form = ClosedForm(exponents, tuple(c for *_, c in terms))
    h1, s1 = h0 + width[0], s0 + width[1]
    H, S = np.meshgrid(np.linspace(h0, h1, 41), np.linspace(s0, s1, 41), indexing="ij")
    values = form(S / H, 2 * H * H / (1 + H * H))
    spread = 1e-3 * (1.0 + np.ptp(values))
    for limit in (np.median(values), values.max() + spread, values.min() - spread):
        bound = Bound(exponents, form.coefficients, float(limit), upper)
        found = first_violation([bound], (h0, h1), (s0, s1))
        holds = values < limit if upper else values > limit
        if found is None:
            assert holds.all()
        elif found.found:
            value = form(found.s / found.h, 2 * found.h**2 / (1 + found.h**2))
            assert not (value < limit if upper else value > limit)
            assert h0 <= found.h <= h1 and s0 <= found.s <= s1
        if not holds.all():
            assert found is not None


def test_bernstein_coefficients_at_the_corners_are_the_values_there():
    bound = Bound(((0, 0), (1, -2), (-3, 4)), (0.5, 0.1, -0.02), 0.25, upper=False)
    h0, h1, s0, s1 = 0.4, 0.9, 0.05, 0.3
    polys = _polynomials([bound])
    proven, hints = _proven(polys, np.array([[h0, h1, s0, s1]]))
    # F (P − lo) at (h, s), with F = s^3 h^5 (1 + h²)^4 for these powers
    form = ClosedForm(bound.exponents, bound.coefficients)

    def times_f(h, s):
        return (form(s / h, 2 * h * h / (1 + h * h)) - 0.25) * s**3 * h**5 * (1 + h * h) ** 4

    from dpfexplore.model.set_checks.bounds import _bernstein_matrices

    Lh = _bernstein_matrices(np.array([h0]), np.array([h1]), polys.shape[2] - 1)[0]
    Ls = _bernstein_matrices(np.array([s0]), np.array([s1]), polys.shape[3] - 1)[0]
    B = Lh @ polys[0, 0] @ Ls.T
    for (i, j), (h, s) in {(0, 0): (h0, s0), (-1, 0): (h1, s0), (0, -1): (h0, s1)}.items():
        np.testing.assert_allclose(B[i, j], times_f(h, s), rtol=1e-12)
    assert hints.shape == (1, 1, 2) and proven.shape == (1, 1)


# --------------------------------------------------------------------------- malformed files


def test_malformed_numbers_and_types_are_refused_in_one_line(tmp_path, capsys):
    data = paper_data()
    data["provenance"] = [1, 2]
    refused(write_set(tmp_path / "prov.json", data), "provenance must be a table, not a list")
    cli_refused(capsys, str(tmp_path / "prov.json"), "provenance must be a table")

    big = 10**400
    data = paper_data()
    data["k_hat"]["terms"][0]["coefficient"] = big
    refused(write_set(tmp_path / "coef-int.json", data), "coefficient: must be a number within")
    data = paper_data()
    data["domain"]["E"] = [5.0, big]
    refused(write_set(tmp_path / "dom-int.json", data), "domain.E must be [low, high] with")
    text = json.dumps(paper_data())
    for name, old, new, says in (
        ("coef-float", '"coefficient": 4.2', '"coefficient": 1e400', "1e400 is beyond a float"),
        ("dom-float", '"E": [5.0', '"E": [1e400', "1e400 is beyond a float"),
        ("nan", '"coefficient": 4.2', '"coefficient": NaN', "NaN is not a number"),
        ("inf", '"coefficient": 4.2', '"coefficient": -Infinity', "-Infinity is not a number"),
        ("format", '"format": "dpfexplore-constants/1"', '"format": 1', "format of type int"),
    ):
        assert old in text
        path = tmp_path / f"{name}.json"
        path.write_text(text.replace(old, new, 1))
        refused(path, says)
    cli_refused(capsys, str(tmp_path / "nan.json"), "NaN is not a number")
    for name in (["paper"], "two\nlines", ""):
        data = paper_data()
        data["name"] = name
        refused(write_set(tmp_path / "name.json", data), "name must be a line of text")

    deep = tmp_path / "deep.json"
    deep.write_text('{"provenance": ' + "[" * 200_000 + "]" * 200_000 + "}")
    refused(deep, "not a constants set (JSON nested too deeply)")
    cli_refused(capsys, str(deep), "nested too deeply")
    data = paper_data()
    data["provenance"] = {"notes": json.loads("[" * 40 + "]" * 40)}  # parses; deeper than 32
    refused(write_set(tmp_path / "nested.json", data), "nested more than 32 deep")


def test_special_and_large_files_are_refused_before_reading(tmp_path, capsys):
    folder = tmp_path / "folder.json"
    folder.mkdir()
    refused(folder, "is a directory, not a file")
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    refused(fifo, "not a regular file (a FIFO)")  # refused without blocking on the pipe
    cli_refused(capsys, "/dev/zero", "/dev/zero: not a regular file (a device or socket)")
    large = tmp_path / "large.json"
    with open(large, "wb") as fh:
        fh.truncate(MAX_SET_BYTES + 1)  # sparse: nothing to write, nothing read
    refused(large, f"{MAX_SET_BYTES + 1} bytes, more than the limit of {MAX_SET_BYTES}")
    refused(tmp_path / "missing.json", "cannot read (No such file or directory)")
    long = "a" * 5000
    with pytest.raises(ConstantsSetError, match=r"cannot read \(File name too long\)"):
        find_constants_set(long)


def test_a_scene_naming_dev_zero_as_its_constants_is_refused(tmp_path, capsys):
    scene = (ROOT / "jobs" / "design-position-cheetah.toml").read_text()
    needle = 'material = "cheetah-95a"'
    assert needle in scene
    (tmp_path / "scene.toml").write_text(
        scene.replace(needle, f'{needle}\nconstants = "/dev/zero"')
    )
    code = main(["design", str(tmp_path / "scene.toml"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err, err
    assert err.endswith(
        "scene.constants = '/dev/zero': /dev/zero: not a regular file (a device or socket)"
        f" (in {tmp_path / 'scene.toml'})"
    )
    assert not (tmp_path / "out").exists()
