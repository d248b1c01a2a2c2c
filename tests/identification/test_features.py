"""The spring law by features: exact on the law's own curves, to noise level on noisy ones."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from dpfexplore.cli import main
from dpfexplore.identification.curves import curves_from_frame
from dpfexplore.identification.features import (
    PathCurve,
    feature_curves_from_frame,
    fit_features,
    quartic_from_features,
)
from dpfexplore.identification.identify import identify
from dpfexplore.identification.spring_fit import spring_energy, spring_force
from dpfexplore.identification.synthetic import synthetic_curves
from dpfexplore.model.constants_set import DEFAULT

# H = 3: t = 0.83 and 1 are metastable in the paper's set (no inverted rest: the ghost is used)
H_GRID = [3.0, 3.5, 4.2, 5.0]
T_GRID = [0.5, 0.7, 0.83, 1.0]


def _truth(curve):
    values = DEFAULT.evaluate(curve.H, curve.t, curve.r_b, curve.E)
    return float(values["k_b"]), float(values["alpha"]), float(values["tip_dis"]) - curve.H


@pytest.mark.parametrize(
    ("k_b", "alpha", "d"), [(2.0, 0.05, 4.0), (7.5, 0.11, 6.0), (3.0, 0.2, 5.0), (1.0, 0.0, 2.0)]
)
def test_the_features_of_a_quartic_give_it_back_exactly(k_b, alpha, d):
    a2, a3, a4 = 0.5 * k_b, -k_b * (1 - alpha) / d, 0.5 * k_b * (1 - alpha) / d**2
    if alpha < 1 / 9:  # the inverted rest and its energy
        x = (-3 * a3 + np.sqrt(9 * a3 * a3 - 32 * a2 * a4)) / (8 * a4)
        got = quartic_from_features(k_b, "rest", x, float(spring_energy(x, k_b, alpha, d)))
    else:  # the ghost: least force
        x = (-6 * a3 + np.sqrt(36 * a3 * a3 - 96 * a2 * a4)) / (24 * a4)
        got = quartic_from_features(k_b, "ghost", x, float(spring_force(x, k_b, alpha, d)))
    np.testing.assert_allclose(got, (a2, a3, a4), rtol=1e-12)


def test_noise_free_curves_of_the_paper_set_are_recovered_exactly():
    frame = synthetic_curves(H_GRID, T_GRID, [5.0], [26.0], noise=0.0)
    kinds = set()
    for curve in feature_curves_from_frame(frame):
        fit = fit_features(curve)
        k_b, alpha, d = _truth(curve)
        assert fit.ok, fit.flags
        assert fit.k_b == pytest.approx(k_b, rel=1e-9)
        assert fit.alpha == pytest.approx(alpha, abs=2e-6)
        assert fit.d == pytest.approx(d, rel=1e-4)
        # matched features exactly; unmatched ones to the sampling of the curve (200 points)
        assert all(abs(r) < 5e-3 for r in fit.residuals.values()), fit.residuals
        kinds.add("ghost" if "far_force" in fit.features else "rest")
    assert kinds == {"rest", "ghost"}


def test_noisy_curves_are_recovered_to_noise_level():
    frame = synthetic_curves(H_GRID, T_GRID, [5.0], [12.0, 26.0], noise=0.01, seed=3)
    errors = []
    for curve in feature_curves_from_frame(frame):
        fit = fit_features(curve)
        k_b, alpha, d = _truth(curve)
        assert fit.ok, fit.flags
        errors.append((fit.k_b / k_b - 1, fit.alpha - alpha, fit.d / d - 1))
    errors = np.abs(np.array(errors))
    median, worst = np.median(errors, axis=0), errors.max(axis=0)
    assert median[0] < 0.01 and worst[0] < 0.03  # k_b, relative
    assert median[1] < 0.002 and worst[1] < 0.012  # alpha, absolute
    assert median[2] < 0.005 and worst[2] < 0.05  # d, relative (worst: metastable units)


def _folded_frame(k_b=2.0, alpha=0.05, d=4.0):
    """The law's path as two overlapping branches (the second lifted where they overlap)."""
    x = np.linspace(0, 5.2, 300)
    energy, force = spring_energy(x, k_b, alpha, d), spring_force(x, k_b, alpha, d)
    rows = []
    for branch, keep, lift in ((0, x <= 3.0, 0.0), (1, x >= 2.0, 0.3)):
        e = energy[keep] + lift * (x[keep] < 3.0)
        part = {"displacement": x[keep], "energy": e, "force": force[keep], "branch": branch}
        rows.append(pd.DataFrame(part))
    return pd.concat(rows).assign(curve="c", H=3.5, t=0.7, r_b=5.0, E=26.0, nu=0.35)


def test_a_folded_curve_takes_its_slope_from_the_first_branch():
    frame = _folded_frame()
    (curve,) = feature_curves_from_frame(frame)
    assert isinstance(curve, PathCurve) and curve.folded and curve.start_force is not None
    fit = fit_features(curve)
    assert fit.ok and fit.k_b == pytest.approx(2.0, rel=1e-6)
    assert fit.alpha == pytest.approx(0.05, abs=1e-4) and fit.d == pytest.approx(4.0, rel=1e-3)
    # the plain envelope has lost the first branch's points: flagged
    (plain,) = curves_from_frame(frame)
    assert any("first branch" in flag for flag in fit_features(plain).flags)


def test_a_curve_without_a_far_state_is_flagged():
    x = np.linspace(0, 3, 100)  # a stiffening spring: no peak, no rest, no ghost
    frame = pd.DataFrame({"displacement": x, "energy": x**2 + x**4, "force": 2 * x + 4 * x**3})
    frame = frame.assign(curve="c", H=3.5, t=0.7, r_b=5.0, E=26.0, nu=0.35)
    fit = fit_features(feature_curves_from_frame(frame)[0])
    assert not fit.ok and "no far state" in fit.flags[0]


def test_identify_and_the_cli_take_the_features_method(tmp_path, capsys):
    frame = synthetic_curves(np.linspace(3, 5, 5), np.linspace(0.5, 1, 5), [5.0], [26.0])
    result = identify(feature_curves_from_frame(frame), name="f", method="features")
    assert result.constants.provenance["settings"]["fit"] == "features"
    values, truth = (
        result.constants.evaluate(4.0, 0.75, 5.0, 26.0),
        DEFAULT.evaluate(4, 0.75, 5, 26),
    )
    assert float(values["alpha"]) == pytest.approx(float(truth["alpha"]), abs=0.003)
    assert float(values["k_b"]) == pytest.approx(float(truth["k_b"]), rel=0.02)
    with pytest.raises(ValueError, match="method"):
        identify(feature_curves_from_frame(frame), name="f", method="nope")

    table = tmp_path / "curves.parquet"
    frame.to_parquet(table)
    out = tmp_path / "set"
    argv = ["identify", "fit", str(table), "--out", str(out), "--method", "features", "--json"]
    assert main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["curves"] == 25 and report["curves_flagged"] == 0
