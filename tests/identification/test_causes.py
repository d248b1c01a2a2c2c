"""The causes report: its least-squares recipes on curves with a known law, one dome's rows."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dpfexplore.identification.causes import (
    DATA,
    FINGER_CASES,
    WEIGHTS,
    box_set,
    curve_definitions,
    fit_recipes,
    least_squares_quartic,
    summarise,
    unit_rows,
)
from dpfexplore.identification.spring_fit import spring_energy, spring_force
from dpfexplore.model.constants_set import DEFAULT, ConstantsSetError
from dpfexplore.unitcell import unit_cell_curve
from dpfexplore.unitcell.reach import hinge_stiffness


@pytest.mark.parametrize("weight", WEIGHTS)
@pytest.mark.parametrize(("k_b", "alpha", "d"), [(6.0, 0.04, 8.0), (12.0, 0.1, 6.5)])
def test_every_weighting_gives_a_laws_own_constants_back(weight, k_b, alpha, d):
    x = np.linspace(0.0, 1.2 * d, 300)
    energy, force = spring_energy(x, k_b, alpha, d), spring_force(x, k_b, alpha, d)
    found = least_squares_quartic(x, energy, force, weight)
    assert found == pytest.approx((k_b, alpha), rel=1e-9)
    rng = np.random.default_rng(4)
    noisy = energy + 0.01 * np.sqrt(np.mean(energy**2)) * rng.standard_normal(x.size)
    k, a = least_squares_quartic(x, noisy, force, weight)
    assert k == pytest.approx(k_b, rel=0.05) and a == pytest.approx(alpha, abs=0.01)


def test_the_curve_definitions_of_a_folded_path():
    run = unit_cell_curve(4.0, 0.75)
    curves = curve_definitions(run)
    assert set(curves) == set(DATA)
    fold = run.folds[0]
    x, energy, _ = curves["to_fold"]
    assert x[-1] == pytest.approx(fold) and np.all(np.diff(energy) > 0)
    x, energy, force = curves["jump"]
    assert x[-1] == pytest.approx(run.tip_dis)
    drop = np.argmax(x > fold)
    assert energy[drop] < energy[drop - 1]  # the jump onto the inverted branch at the fold
    assert abs(force[-1]) < 0.05 * np.abs(force).max()  # it ends at the rest
    x, energy, _ = curves["envelope"]
    assert np.all(energy <= curves["jump"][1][: energy.size] + 1e-9)  # the lower envelope
    recipes = fit_recipes(run)
    assert {"states", "features (slope)", "barrier", "states 1:2"} <= set(recipes)
    assert len(recipes) == len(DATA) * len(WEIGHTS) + 5


def test_one_domes_rows_and_their_tables():
    assert 0.8 < hinge_stiffness(0.75) < 1.2  # N/mm: a finger's hinge gives easily
    frame = pd.DataFrame(unit_rows(4.0, 0.75, n_elements=64))
    assert set(frame["cause"]) == {"fit", "edge", "reach"}
    summary = summarise(frame)
    tips = {row["model"]: row for row in summary["tip_models"]}
    # the square face lets the dome reach further than the pinned cap; contact shortens it
    assert tips["square pinned"]["tip_ratio"][1] > tips["cap pinned"]["tip_ratio"][1]
    assert tips["two-unit, hinge"]["tip_ratio"][1] < tips["cap pinned"]["tip_ratio"][1]
    states = {row["recipe"]: row for row in summary["fit_recipes"]}["states"]
    assert states["valid"] == 1 and 0.5 < states["k_b_ratio"][1] < 1.0


def test_a_box_set_from_the_record_reproduces_its_domes():
    record = Path(__file__).parents[2] / "results" / "reports" / "unitcell-causes.json"
    units = json.loads(record.read_text())["units"]
    constants = box_set(units, "states, cell", "cap pinned: states", "square pinned")
    for key in ("3, 0.5", "4, 0.8", "5, 1"):
        H, t = (float(v) for v in key.split(","))
        values = constants.evaluate(H, t, 5.0, 26.0)
        k_b, alpha = units[key]["cap pinned: states"]
        assert float(values["k_b"]) == pytest.approx(k_b, rel=0.02)
        assert float(values["alpha"]) == pytest.approx(alpha, abs=0.003)
        assert float(values["tip_dis"]) == pytest.approx(
            units[key]["tip: square pinned"][0], rel=0.02
        )
    # the paper's forms where a case names none; a recipe with alpha <= 0 is refused
    paper = box_set(units, "paper", None, None)
    assert paper.k_hat == DEFAULT.k_hat and paper.alpha == DEFAULT.alpha
    assert {case[1] for case in FINGER_CASES} >= {None, "cap pinned: states"}
    with pytest.raises(ConstantsSetError):
        box_set(units, "envelope", "cap pinned: envelope, energy+force", "square pinned")
