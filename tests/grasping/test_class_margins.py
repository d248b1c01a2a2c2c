"""The classes' margins (dpfexplore.grasping.classes) against a hand computation.

The loop is replaced by a synthetic one whose boundaries and payloads are known in closed form:
sized by state 0 from 70 mm up, 1 from 55, 2 from 40, 3 from 30, none below; payload
``P(D) = D / 50`` g without the tip unit and ``2 P`` with it. Every margin below is then a few
lines of arithmetic, written out beside each assertion.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dpfexplore._kernels.grasp import batch as kb
from dpfexplore.grasping import classes as classes_module
from dpfexplore.grasping.classes import ObjectClass, class_margins, class_samples
from dpfexplore.grasping.setup import GRAVITY

CUTS = (70.0, 55.0, 40.0, 30.0)
STATES = ("10000", "11000", "11100", "11110")


def fake_loop(gripper, diameters, weights_N, **_):
    """The synthetic loop's table (columns of the batch kernel) for an infinite weight."""
    d = np.asarray(diameters, dtype=float)
    size = np.full(d.size, -1)
    for j, cut in reversed(list(enumerate(CUTS))):
        size[d >= cut] = j
    table = np.zeros((d.size, kb.N_SORT))
    table[:, kb.S_SIZE] = size
    payload = 1e-3 * d / 50.0 * GRAVITY  # N
    table[:, kb.S_PAYLOAD] = np.where(size >= 0, payload, np.nan)
    table[:, kb.S_PAYLOAD_TIP] = np.where(size >= 0, 2 * payload, np.nan)
    return table


@pytest.fixture
def synthetic(monkeypatch):
    monkeypatch.setattr(classes_module, "run_sort", fake_loop)
    return SimpleNamespace(
        open_aperture=90.0,
        states=STATES,
        default_depth=lambda: 50.0,
        threshold=lambda margin: 0.25,
    )


def test_margins_by_hand(synthetic):
    light = ObjectClass("light", (60.0, 64.0), (0.5e-3, 1.0e-3))
    heavy = ObjectClass("heavy", (44.0, 47.0), (1.0e-3, 1.5e-3))
    out = class_margins(synthetic, [light, heavy], tol=1e-3)
    np.testing.assert_allclose(out.boundaries_mm, CUTS, atol=1e-3)
    a, b = out.classes
    # light: centre 62 mm in [55, 70) -> 11000; P(62) = 1.24 g >= 0.75 g -> light
    assert a.label == "11000/light"
    assert a.size_margin_mm == pytest.approx(min(60 - 55, 70 - 64), abs=1e-3)  # 5 mm
    assert a.mass_margin_kg == pytest.approx(60 / 50 * 1e-3 - 1.0e-3, abs=1e-12)  # 0.2 g
    assert a.margin == pytest.approx(0.2, abs=1e-9)  # min(5 / 1 mm, 0.2 g / 1 g)
    # heavy: centre 45.5 mm -> 11100; P = 0.91 g < 1.25 g <= T = 1.82 g -> heavy. Its whole
    # mass range stays heavy while P(D) < m_lo = 1 g, i.e. D < 50 mm, inside [40, 55) of 11100:
    # the interval is [40, 50] and the diameter margin min(44 - 40, 50 - 47) = 3 mm. Over the
    # box min(m_lo - max P, min T - m_hi) = min(1.0 - 0.94, 1.76 - 1.5) g = 0.06 g
    assert b.label == "11100/heavy"
    assert b.interval_mm == pytest.approx((40.0, 50.0), abs=1e-3)
    assert b.size_margin_mm == pytest.approx(3.0, abs=1e-3)
    assert b.mass_margin_kg == pytest.approx(0.06e-3, abs=1e-12)
    assert out.margin == pytest.approx(0.06, abs=1e-9) and a.correct and b.correct
    # other scales: 2 mm of diameter as 0.1 g of mass
    scaled = class_margins(synthetic, [light], diameter_scale=2.0, mass_scale=1e-4, tol=1e-3)
    assert scaled.margin == pytest.approx(min(5 / 2.0, 0.2 / 0.1), abs=1e-3)  # 2.0


def test_misclassified_classes_are_negative(synthetic):
    across = ObjectClass("across", (37.0, 41.0), (0.0, 0.2e-3))  # centre 39 -> [30, 40)
    unsized = ObjectClass("unsized", (20.0, 24.0), (0.0, 0.2e-3))  # below 30 mm: none
    too_heavy = ObjectClass("too-heavy", (60.0, 62.0), (3.0e-3, 4.0e-3))  # T(60) = 2.4 g
    out = class_margins(synthetic, [too_heavy, across, unsized], tol=1e-3)
    m = {c.name: c for c in out.classes}
    assert m["across"].size_margin_mm == pytest.approx(40 - 41, abs=1e-3)  # -1 mm
    assert m["unsized"].label == "none/not_held"
    # not held: half its width, and 8 mm from its centre (22) to the first diameter that holds
    # 0.2 g (30 mm, sized there)
    assert m["unsized"].size_margin_mm == pytest.approx(-(2.0 + 8.0))
    # not held: min over the box of max(P, T) - m_hi = 2 * 60 / 50 - 4 = -1.6 g
    assert m["too-heavy"].label == "11000/not_held"
    assert m["too-heavy"].mass_margin_kg == pytest.approx(-1.6e-3, abs=1e-12)
    # no diameter up to the open gripper holds 4 g (T >= 4 g from 100 mm): the whole grid,
    # 90 - 10 mm, beyond half its width
    assert m["too-heavy"].size_margin_mm == pytest.approx(-(1.0 + 80.0))
    assert all(not c.correct for c in out.classes) and out.margin < 0
    # past the open gripper (90 mm): the interval ends there, 4 mm inside the class
    wide = class_margins(synthetic, [ObjectClass("wide", (88.0, 94.0), (0.0, 0.2e-3))], tol=1e-3)
    assert wide.classes[0].size_margin_mm == pytest.approx(90 - 94)
    # the same outcome for two classes: both get the half-width penalty
    twin = ObjectClass("twin", (64.0, 66.0), (0.0, 0.2e-3))
    light = ObjectClass("light", (57.0, 59.0), (0.0, 0.2e-3))
    shared = class_margins(synthetic, [twin, light], tol=1e-3)
    assert [c.size_margin_mm for c in shared.classes] == [-1.0, -1.0]


def test_tip_unit_not_lasting_gives_no_heavy_class(synthetic):
    heavy = ObjectClass("heavy", (44.0, 46.0), (1.0e-3, 1.5e-3))
    out = class_margins(synthetic, [heavy], tip_lasts=False, tol=1e-3)
    assert out.classes[0].label == "11100/not_held"
    # max(P, 0) - m_hi over the box: 0.88 - 1.5 g
    assert out.classes[0].mass_margin_kg == pytest.approx(0.88e-3 - 1.5e-3, abs=1e-12)
    # P >= 1.5 g from 75 mm: 30 mm from its centre, beyond half its width
    assert out.classes[0].size_margin_mm == pytest.approx(-(1.0 + 30.0))


def test_samples_cover_the_box_edges():
    c = ObjectClass("c", (10.0, 12.0), (1e-3, 2e-3))
    point = ObjectClass("p", (20.0, 20.0), (5e-4, 5e-4))
    s = class_samples([c, point])
    assert s.classes.count("c") == 15 and s.classes.count("p") == 1
    d = s.diameters[:15].reshape(5, 3)
    m = s.masses[:15].reshape(5, 3)
    np.testing.assert_allclose(d[:, 0], [10.0, 10.5, 11.0, 11.5, 12.0])
    np.testing.assert_allclose(m[0], [1e-3, 1.5e-3, 2e-3])
