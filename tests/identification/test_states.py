"""The spring law by the unit's states: exact on the law's own curves, the shell's saddle found."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dpfexplore.cli import main
from dpfexplore.identification.curves import curves_from_frame
from dpfexplore.identification.identify import DEFAULT_METHOD, identify
from dpfexplore.identification.states import (
    StatesCurve,
    _law_barrier,
    fit_states,
    states_curves_from_frame,
)
from dpfexplore.identification.synthetic import synthetic_curves
from dpfexplore.model.constants_set import DEFAULT

# metastable in the paper's set (no inverted rest: the ghost's law): H = 3 with t = 0.83 and 1,
# H = 3.5 with t = 1
H_GRID = [3.0, 3.5, 4.2, 5.0]
T_GRID = [0.5, 0.7, 0.83, 1.0]


def _truth(curve):
    values = DEFAULT.evaluate(curve.H, curve.t, curve.r_b, curve.E)
    return float(values["k_b"]), float(values["alpha"])


def test_noise_free_curves_of_the_paper_set_are_recovered_exactly():
    frame = synthetic_curves(H_GRID, T_GRID, [5.0], [26.0], noise=0.0)
    balanced = 0
    for curve in states_curves_from_frame(frame):
        fit = fit_states(curve)
        k_b, alpha = _truth(curve)
        assert fit.ok, fit.flags
        assert fit.k_b == pytest.approx(k_b, rel=1e-6)
        assert fit.alpha == pytest.approx(alpha, abs=1e-6)
        if "saddle_energy" in fit.features:  # a rest: slope and barrier both met at the truth
            balanced += 1
            assert abs(fit.residuals["slope"]) < 1e-6
            assert abs(fit.residuals["saddle_energy"]) < 1e-6
    assert balanced == 13  # the three metastable ones take the ghost's law


def test_noisy_curves_are_recovered_to_noise_level():
    frame = synthetic_curves(H_GRID, T_GRID, [5.0], [12.0, 26.0], noise=0.01, seed=3)
    errors = []
    for curve in states_curves_from_frame(frame):
        fit = fit_states(curve)
        k_b, alpha = _truth(curve)
        assert fit.ok, fit.flags
        errors.append((fit.k_b / k_b - 1, fit.alpha - alpha))
    errors = np.abs(np.array(errors))
    median, worst = np.median(errors, axis=0), errors.max(axis=0)
    assert median[0] < 0.01 and worst[0] < 0.03  # k_b, relative
    assert median[1] < 0.002 and worst[1] < 0.012  # alpha, absolute


def test_the_law_between_a_stiff_start_and_a_low_barrier_splits_the_difference():
    # features of a quartic, then a barrier 3/4 of the law's (still above its rest's energy):
    # the fit moves k_b below the slope
    frame = synthetic_curves([4.0], [0.7], [5.0], [26.0], noise=0.0)
    (curve,) = states_curves_from_frame(frame)
    exact = fit_states(curve)
    lowered = StatesCurve(
        **{
            **curve.__dict__,
            "folded": True,
            "start_displacement": curve.displacement,
            "start_energy": curve.energy,
            "start_force": curve.force,
            "zero_force": ((3.0, 0.75 * _law_barrier(exact.k_b, exact.alpha, exact.d)),),
        },
    )
    fit = fit_states(lowered)
    assert fit.k_b < exact.k_b and fit.alpha > exact.alpha
    # the two relative misfits share the difference: the law's k_b below the slope, its barrier
    # above the one given
    assert fit.residuals["slope"] < 0 < fit.residuals["saddle_energy"]
    assert fit.features["far_energy"] == pytest.approx(fit.law["far_energy"], rel=1e-9)


def test_the_shell_path_gives_its_lowest_saddle_as_the_barrier():
    from dpfexplore.unitcell import unit_cell_curve

    run = unit_cell_curve(4.0, 0.75)
    (curve,) = states_curves_from_frame(run.to_frame())
    saddle = min(z.energy for z in run.zero_force_states if z.index == 1)
    fit = fit_states(curve)
    assert fit.ok and fit.features["saddle_energy"] == pytest.approx(saddle, rel=1e-3)
    assert fit.features["far_displacement"] == pytest.approx(run.tip_dis, rel=1e-3)
    # read as a plain envelope, its folds' crossing is no zero-force state: flagged
    (plain,) = curves_from_frame(run.to_frame())
    assert not fit_states(plain).ok


def test_identify_and_the_cli_default_to_the_states_method(tmp_path, capsys):
    assert DEFAULT_METHOD == "states"
    frame = synthetic_curves(np.linspace(3, 5, 5), np.linspace(0.5, 1, 5), [5.0], [26.0])
    result = identify(states_curves_from_frame(frame), name="s")
    assert result.constants.provenance["settings"]["fit"] == "states"
    values, truth = (
        result.constants.evaluate(4.0, 0.75, 5.0, 26.0),
        DEFAULT.evaluate(4, 0.75, 5, 26),
    )
    assert float(values["alpha"]) == pytest.approx(float(truth["alpha"]), abs=0.003)
    assert float(values["k_b"]) == pytest.approx(float(truth["k_b"]), rel=0.02)
    table = tmp_path / "curves.parquet"
    frame.to_parquet(table)
    out = tmp_path / "set"
    assert main(["identify", "fit", str(table), "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["curves"] == 25 and report["curves_flagged"] == 0
    assert json.loads((out / "constants.json").read_text())["provenance"]["settings"]["fit"] == (
        "states"
    )
