"""The fast reset-time model (``reset_times_batch(..., method="fast")``).

Its physics against independent computations (SciPy on the same equations, the full model), its
fitted trees against scikit-learn, its model file, its agreement with the full model within the
stated interval, its fallback, and its CLI and sweep option.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.optimize as so
from conftest import reference_reset_times

from dpfexplore._kernels.dynamics import motion as kd
from dpfexplore._kernels.dynamics.events import (
    CTRL_H_INIT,
    CTRL_H_MAX,
    N_REC,
    N_STATS,
    REC_LAST_DOWN,
)
from dpfexplore._kernels.layout import COL_ALPHA, COL_U_INV
from dpfexplore._kernels.records import MotionModel, MotionScratch, ReleaseRecord
from dpfexplore._kernels.reset.loaded_state import (
    FTOL,
    MAX_ITER,
    MAX_MOVE,
    extension_guess,
    force_peak_extension,
    loaded_newton,
    loaded_state,
    newton_scratch,
)
from dpfexplore._kernels.reset.release import release_rodas3, release_workspace
from dpfexplore._kernels.statics.newton import workspace
from dpfexplore.model import status as st
from dpfexplore.model.design import Design, DesignBatch
from dpfexplore.solvers.dynamics import fast_reset as fr
from dpfexplore.solvers.dynamics.common import METHODS, controls
from dpfexplore.solvers.dynamics.reset_model import (
    DEFAULT_MODEL_PATH,
    ResetModel,
    TreeEnsemble,
    load_reset_model,
)
from dpfexplore.solvers.dynamics.simulate import PressureProfile, reset_times_batch, simulate
from dpfexplore.solvers.lattice import lattice_params

PULSE = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
T_END = 15.0
#: The pick-and-place finger's reset times (s) of units 5-6, from the reference integration
#: (SciPy Radau, tests/data/reference/pickplace_dynamics.csv; interpolated to ~5e-4 s).
PICKPLACE_RESETS = tuple(reference_reset_times())


def _residual(x, params, pressure):
    n = x.shape[0]
    nodes = 2 * params.n_units + 2
    out = np.empty(n)
    kd.force_residual(
        x,
        np.zeros(n),
        0.0,
        MotionModel(
            params.unit_params, params.h, np.zeros(1), np.full(1, pressure), np.zeros(kd.N_PHYS)
        ),
        MotionScratch(np.empty((nodes, 2)), np.empty((nodes, 2)), np.empty(n)),
        out,
    )
    return out


@pytest.mark.parametrize("alpha", [0.02, 0.05, 0.1, 0.1131, 0.2, 0.3])
def test_force_peak_extension_is_the_isolated_force_maximum(alpha):
    # the isolated dome's force per k_b d, maximised numerically on the rising branch
    force = lambda u: -(u * (1.0 + (1.0 - alpha) * (2.0 * u * u - 3.0 * u)))  # noqa: E731
    found = so.minimize_scalar(force, bounds=(0.0, 0.5), method="bounded", options={"xatol": 1e-12})
    assert force_peak_extension(alpha) == pytest.approx(found.x, abs=1e-6)


def test_force_peak_extension_without_a_peak():
    # α >= 1/3: the force rises monotonically, the hold falls back to a quarter of the reach
    assert force_peak_extension(0.4) == 0.25


def test_loaded_newton_matches_scipy_root(pickplace):
    params = lattice_params(pickplace)
    n = 4 * pickplace.n_units - 2
    x = np.empty(n)
    extension_guess(params.unit_params, params.h, np.full(pickplace.n_units, 1.3), x)
    start = x.copy()
    code, n_iter = loaded_newton(
        x,
        params.unit_params,
        params.h,
        0.7,
        FTOL,
        MAX_ITER,
        MAX_MOVE,
        newton_scratch(pickplace.n_units),
    )
    assert code == st.OK and 0 < n_iter < 20
    assert np.abs(_residual(x, params, 0.7)).max() < 1e-7
    root = so.root(_residual, start, args=(params, 0.7), method="hybr", tol=1e-13)
    assert root.success
    np.testing.assert_allclose(x, root.x, atol=1e-8)


def _full_model_snapped(design, P0):
    """Units the full model has snapped by the end of the hold (ever inverted before τ3)."""
    run = simulate(
        design, PressureProfile((0.0, 1.0, 5.0), (0.0, P0, P0)), t_end=5.0, n_samples=0, atol=1e-6
    )
    return ~np.isnan(run.snap_through)


@pytest.mark.parametrize("P0", [0.7, 0.35])
def test_loaded_state_snaps_what_the_full_loading_snaps(pickplace, P0):
    params = lattice_params(pickplace)
    n_units = pickplace.n_units
    x = np.empty(4 * n_units - 2)
    margin = np.empty(n_units)
    u = np.empty(n_units)
    code, pattern, _ = loaded_state(params.unit_params, params.h, P0, x, margin, u)
    assert code == st.OK
    snapped = np.array([(pattern >> (n_units - 1 - k)) & 1 for k in range(n_units)], bool)
    np.testing.assert_array_equal(snapped, _full_model_snapped(pickplace, P0))
    assert not snapped.all() or P0 == 0.7  # the lower pressure leaves some domes unsnapped
    # the margins say which side each decision fell on; the state is a loaded equilibrium
    np.testing.assert_array_equal(margin < 0.0, snapped)
    np.testing.assert_array_equal(u > params.unit_params[:, COL_U_INV], snapped)
    assert np.abs(_residual(x, params, P0)).max() < 1e-6


def test_release_matches_the_overdamped_full_model(pickplace):
    """From the same loaded state, Rodas3 and the full model's overdamped Rodas4 agree."""
    params = lattice_params(pickplace)
    n_units = pickplace.n_units
    x0 = np.empty(4 * n_units - 2)
    code, _, _ = loaded_state(
        params.unit_params, params.h, 0.7, x0, np.empty(n_units), np.empty(n_units)
    )
    assert code == st.OK
    # the full model from x0 under the release ramp alone (times shifted by τ3 = 5 s)
    ramp = PressureProfile((0.0, 0.1), (0.7, 0.0))
    full = simulate(
        pickplace,
        ramp,
        t_end=10.0,
        x0=x0,
        method="rodas4-overdamped",
        atol=1e-9,
        n_samples=0,
        stop_when_reset=True,
    )
    errors = []
    for atol in (1e-3, 1e-6):
        ctrl = controls(
            METHODS["rodas4-overdamped"],
            t_release=5.1,
            atol=atol,
            rtol=None,
            h_max=5.0,
            max_steps=100_000,
            stop_when_reset=True,
        )
        ctrl[CTRL_H_INIT] = 0.02
        ctrl[CTRL_H_MAX] = 5.0
        rec = np.empty((n_units, N_REC))
        stats = np.zeros(N_STATS, dtype=np.int64)
        phys = np.array([kd.ETA_INTERNAL, kd.ETA_ISO, 0.0])
        code = release_rodas3(
            x0.copy(),
            MotionModel(params.unit_params, params.h, PULSE.knots()[0], PULSE.knots()[1], phys),
            ctrl,
            5.0,
            15.0,
            ReleaseRecord(rec, stats, np.empty((n_units, 2)), np.zeros(2, dtype=np.int64)),
            release_workspace(n_units),
            workspace(),
        )
        assert code == st.OK
        reset = rec[4:, REC_LAST_DOWN] - 5.1  # units 5 and 6 reset: last downward crossings
        errors.append(np.abs(reset / full.reset_time[4:] - 1.0).max())
    assert errors[1] < 1e-5 < errors[0] < 1e-2  # converges to the same times as atol shrinks


@pytest.mark.parametrize("loss", ["huber", "quantile"])
def test_tree_ensemble_reproduces_scikit_learn(loss):
    from sklearn.ensemble import GradientBoostingRegressor

    rng = np.random.default_rng(3)
    x = rng.normal(size=(400, 5))
    y = np.sin(x[:, 0]) + 0.3 * x[:, 1] * x[:, 2] + 0.1 * rng.normal(size=400)
    est = GradientBoostingRegressor(
        loss=loss, alpha=0.9, n_estimators=60, max_depth=3, random_state=0
    ).fit(x, y)
    trees = TreeEnsemble.from_gradient_boosting(est)
    probe = rng.normal(size=(200, 5))
    np.testing.assert_allclose(trees.predict(probe), est.predict(probe), rtol=0, atol=1e-12)
    again = TreeEnsemble.from_dict(json.loads(json.dumps(trees.to_dict())))
    np.testing.assert_array_equal(again.predict(probe), trees.predict(probe))


def test_model_file_round_trips_and_refuses_what_it_cannot_use(tmp_path):
    model = load_reset_model()
    copy = model.save(tmp_path / "copy.json")
    again = load_reset_model(copy)
    probe = np.random.default_rng(0).normal(size=(5, len(model.features)))
    np.testing.assert_array_equal(again.correction.predict(probe), model.correction.predict(probe))
    assert again.conformal_q == model.conformal_q and again.domain == model.domain
    good = model.to_dict()
    cases = {
        "format": ({**good, "format": "pickle"}, "format"),
        "version": ({**good, "format_version": 99}, "format_version"),
        "physics": ({**good, "model_version": "other"}, "model_version"),
        "features": ({**good, "features": ["H"]}, "features"),
        "trees": (
            {
                **good,
                "correction": {
                    **good["correction"],
                    "left": [10**6] * len(good["correction"]["left"]),
                },
            },
            "outside",
        ),
    }
    for name, (data, message) in cases.items():
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(data))
        with pytest.raises(ValueError, match=message):
            load_reset_model(path)
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(ValueError, match="not JSON"):
        load_reset_model(tmp_path / "junk.json")
    with pytest.raises(ValueError, match="no such file"):
        load_reset_model(tmp_path / "missing.json")


def test_pickplace_within_its_interval_and_2_percent(pickplace):
    out = reset_times_batch(
        DesignBatch.from_designs([pickplace]), PULSE, t_end=T_END, method="fast"
    )
    assert not out["fallback"][0]
    reset = out["reset_time"][0, 4:6]
    np.testing.assert_allclose(reset, PICKPLACE_RESETS, rtol=0.02)
    assert (out["reset_time_lo"][0, 4:6] <= PICKPLACE_RESETS).all()
    assert (np.array(PICKPLACE_RESETS) <= out["reset_time_hi"][0, 4:6]).all()
    assert np.isinf(out["reset_time"][0, :4]).all() and out["final_state"][0] == 0b111100
    assert out["unit_class"][0, :6].tolist() == [0, 0, 0, 0, 1, 1]
    assert np.isnan(out["snap_through"][0, :6]).all()  # the loading is not integrated
    # snap-back = release + reset time, as the full model reports it; none where no reset
    np.testing.assert_allclose(
        out["snap_back"][0, 4:6], PULSE.t_release + reset, rtol=0, atol=1e-12
    )
    assert np.isnan(out["snap_back"][0, :4]).all()


def test_fast_agrees_with_the_full_model_on_a_seeded_sample():
    from scipy.stats import binom

    from dpfexplore.bench.dynamics import sample_metastable_designs
    from dpfexplore.bench.reset_model import compare

    batch, ref = sample_metastable_designs(48, seed=11)
    out = reset_times_batch(batch, PULSE, t_end=T_END, method="fast")
    figures = compare(out, ref, batch.n_units)
    units = figures["metastable_units"]
    assert units >= 60
    assert figures["class_agreement"] == 1.0
    # 90 % intervals: the covered count of a model with the goal's 88 % coverage falls below
    # this bound with probability 0.1 % (binomial), so a failure means undercoverage
    claimed = figures["coverage_units"]  # units of the rows that did not fall back
    assert figures["coverage_90"] * claimed >= binom.ppf(0.001, claimed, 0.88)
    assert figures["max_rel_err"] < 0.05
    # the sample holds a race of resets (row 31: the core, at its tolerance, resets unit 2 after
    # unit 1, 86 % late): such rows run the full model
    raced = (out["fallback_reason"] & fr.FALLBACK_RACE) != 0
    assert raced.any() and out["fallback"][raced].all()
    np.testing.assert_allclose(out["reset_time"][raced], ref["reset_time"][raced], rtol=1e-3)
    lo, hi, t = out["reset_time_lo"], out["reset_time_hi"], out["reset_time"]
    finite = np.isfinite(t)
    assert (lo[finite] <= t[finite]).all() and (t[finite] <= hi[finite]).all()


def test_fallback_outside_the_domain_runs_the_full_model(pickplace):
    common = {"U_L": 6.0, "U_sep": 1.0, "t": 0.83, "t_lim": 1.0}
    designs = [
        Design(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0, 3.0], **common),  # N = 7 > 6
        Design(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], **{**common, "U_sep": 3.0}),  # U_sep above 2.5 mm
        Design(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], E=12.0, **common),  # another material
        pickplace,
    ]
    batch = DesignBatch.from_designs(designs)
    out = reset_times_batch(batch, PULSE, t_end=T_END, method="fast")
    np.testing.assert_array_equal(out["fallback"], [True, True, True, False])
    assert (out["fallback_reason"][:3] == fr.FALLBACK_DOMAIN).all()
    full = reset_times_batch(batch.take(np.arange(3)), PULSE, t_end=T_END)
    for key in ("reset_time", "unit_class", "final_state", "snap_through"):
        np.testing.assert_array_equal(out[key][:3], full[key])
    np.testing.assert_array_equal(out["reset_time_lo"][:3], full["reset_time"])


@pytest.mark.parametrize(
    ("profile", "t_end"),
    [
        (PressureProfile.pulse(0.6, (0.0, 1.0, 5.0, 5.1)), T_END),  # another pressure
        (PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1)), 5.1 + 40.0),  # beyond the horizon
        (PressureProfile.pulses([(0.7, 0, 1, 2, 2.1), (0.7, 3, 4, 5, 5.1)]), T_END),  # 2 pulses
    ],
)
def test_fallback_outside_the_scene(pickplace, profile, t_end):
    batch = DesignBatch.from_designs([pickplace])
    out = reset_times_batch(batch, profile, t_end=t_end, method="fast")
    assert out["fallback"][0] and out["fallback_reason"][0] == fr.FALLBACK_SCENE
    full = reset_times_batch(batch, profile, t_end=t_end)
    np.testing.assert_array_equal(out["reset_time"], full["reset_time"])


def test_fallback_when_the_interval_is_wider_than_asked(pickplace):
    tall = Design(H=[4.0, 4.5, 5.0, 5.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    batch = DesignBatch.from_designs([pickplace, tall])
    out = reset_times_batch(batch, PULSE, t_end=T_END, method="fast", max_rel_halfwidth=1e-9)
    # the first has metastable units (an interval of finite width), the second resets nothing
    np.testing.assert_array_equal(out["fallback"], [True, False])
    assert out["fallback_reason"][0] == fr.FALLBACK_WIDTH


def test_invalid_design_keeps_its_status_without_fallback(pickplace):
    batch = DesignBatch.from_designs([pickplace])
    bad = DesignBatch(
        **{**{k: getattr(batch, k) for k in batch.ARRAY_FIELDS}, "t": np.array([-1.0])}
    )
    out = reset_times_batch(bad, PULSE, t_end=T_END, method="fast")
    assert out["status"][0] == st.INVALID_INPUT and not out["fallback"][0]
    assert np.isnan(out["reset_time"][0]).all()


def test_fast_input_errors(pickplace):
    batch = DesignBatch.from_designs([pickplace])
    with pytest.raises(ValueError, match="atol"):
        reset_times_batch(batch, PULSE, t_end=T_END, method="fast", atol=1e-3)
    with pytest.raises(ValueError, match="max_rel_halfwidth"):
        reset_times_batch(batch, PULSE, t_end=T_END, method="fast", max_rel_halfwidth=0.0)
    with pytest.raises(ValueError, match="for 'fast'"):
        reset_times_batch(batch, PULSE, t_end=T_END, max_rel_halfwidth=0.1)
    with pytest.raises(ValueError, match="no such file"):
        reset_times_batch(batch, PULSE, t_end=T_END, method="fast", model="missing.json")
    with pytest.raises(ValueError, match="reset times only"):
        simulate(pickplace, PULSE, t_end=T_END, method="fast")


def test_features_are_the_core_values(pickplace):
    batch = DesignBatch.from_designs([pickplace])
    core = fr.fast_reset_core(batch, PULSE, t_end=T_END, atol=3e-3)
    units = np.isfinite(core["reset_time"])
    x = fr.unit_features(batch, core, units)
    names = load_reset_model().features
    assert x.shape == (2, len(names))
    col = {name: x[:, j] for j, name in enumerate(names)}
    np.testing.assert_allclose(np.exp(col["log_T_core"]), core["reset_time"][0, 4:6])
    np.testing.assert_array_equal(col["unit_from_base"], [4, 5])
    np.testing.assert_array_equal(col["unit_from_tip"], [1, 0])
    np.testing.assert_allclose(col["alpha"], lattice_params(pickplace).unit_params[4:, COL_ALPHA])
    np.testing.assert_array_equal(col["alpha_after"][1], 0.0)  # nothing beyond the tip
    assert (col["n_inverted"] == 6).all() and (col["n_reset_core"] == 2).all()


# ----------------------------------------------------------------------------- CLI and sweep


def test_simulate_fast_json_gives_the_models_values(capsys, pickplace):
    from dpfexplore.cli import main
    from dpfexplore.examples import example_path

    code = main(["simulate", str(example_path("pickplace")), "--method", "fast", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    api = reset_times_batch(
        DesignBatch.from_designs([pickplace]), PULSE, t_end=T_END, method="fast"
    )
    assert out["method"] == "fast" and out["fallback"] is False
    assert out["reset_times"][:4] == ["inf"] * 4
    assert out["reset_times"][4:] == pytest.approx(api["reset_time"][0, 4:6].tolist(), abs=1e-9)
    assert (
        out["reset_time_interval"][0][4]
        <= out["reset_times"][4]
        <= out["reset_time_interval"][1][4]
    )
    assert out["final_state"] == "111100" and out["classes"][4] == "metastable"
    # like every command's JSON: the set it ran on and the fitted-range verdict
    from dpfexplore.model.constants_set import DEFAULT

    assert out["constants"]["fingerprint"] == DEFAULT.fingerprint
    assert out["fitted_range"] is True and out["fitted_range_note"] is None


def test_simulate_fast_text(capsys):
    from dpfexplore.cli import main

    assert main(["simulate", "pickplace", "--method", "fast"]) == 0
    text = capsys.readouterr().out
    assert "method fast" in text and "90% interval" in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--method", "fast", "--max-rel-halfwidth", "-1"], "max_rel_halfwidth"),
        (["--method", "fast", "--plot", "run.png"], "--plot"),
        (["--method", "fast", "--reset-model", "missing.json"], "no such file"),
        (["--method", "fast", "--atol", "1e-3"], "atol"),
        (["--max-rel-halfwidth", "0.1"], "--method fast"),
    ],
)
def test_simulate_fast_bad_input_exits_2(capsys, argv, message):
    from dpfexplore.cli import main

    assert main(["simulate", "pickplace", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_reset_model_report(capsys):
    from dpfexplore.cli import main

    assert main(["reset-model", "report"]) == 0
    text = capsys.readouterr().out
    assert "scene: P0 = 0.7 MPa" in text and str(DEFAULT_MODEL_PATH.name) in text
    assert main(["reset-model", "report", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scene"]["tau"] == [0.0, 1.0, 5.0, 5.1] and "correction" not in data


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["report", "missing.json"], "no such file"),
        (["fit", "--out", "model.txt"], "JSON"),
        (["fit", "--out", "m.json", "--initial", "0"], "--initial"),
        (["fit", "--out", "m.json", "--tau", "0,1,5"], "--tau"),
        (["fit", "--out", "m.json", "--atol", "-1"], "--atol"),
    ],
)
def test_reset_model_bad_input_exits_2(capsys, argv, message):
    from dpfexplore.cli import main

    assert main(["reset-model", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_sweep_fast_option_stores_the_models_values(tmp_path):
    from sweep_helpers import make_job

    from dpfexplore.sweep.driver import run_sweep
    from dpfexplore.sweep.sampling import sample_designs
    from dpfexplore.sweep.storage import store

    load = {
        "P0": 0.7,
        "tau": [0.0, 1.0, 5.0, 5.1],
        "t_end": 15.0,
        "method": "fast",
        "max_rel_halfwidth": 0.2,
    }
    variables = {
        "H": {"min": 2.8, "max": 4.0},
        "U_sep": {"min": 1.0, "max": 2.0},
        "U_L": {"min": 5.5, "max": 10.0},
        "t": {"min": 0.75, "max": 1.0},
        "t_lim": {"min": 1.0, "max": 2.0},
    }
    spec = make_job(
        **{
            "job.samples_per_n": 12,
            "space.n_units": [3],
            "space.variables": variables,
            "compute.reset_times": load,
            "compute.stiffness": False,
        }
    )
    run_sweep(spec, tmp_path / "out", chunk_size=6)
    frame = store.read_results(tmp_path / "out").sort_values("sample").reset_index(drop=True)
    batch = sample_designs(spec, 3, 0, 12)
    direct = reset_times_batch(batch, PULSE, t_end=15.0, method="fast", max_rel_halfwidth=0.2)
    np.testing.assert_array_equal(frame["reset_fallback"], direct["fallback"])
    np.testing.assert_array_equal(frame["reset_fallback_reason"], direct["fallback_reason"])
    for k in range(1, 4):
        for name in ("reset_time", "reset_time_lo", "reset_time_hi"):
            np.testing.assert_array_equal(frame[f"{name}_{k}"], direct[name][:, k - 1])
    assert np.isfinite(direct["reset_time"][:, :3]).any()  # some units reset in the sample


def test_job_refuses_a_width_without_the_fast_method():
    from sweep_helpers import make_job

    from dpfexplore.sweep.job_file import JobSpecError

    load = {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0, "max_rel_halfwidth": 0.1}
    with pytest.raises(JobSpecError, match="max_rel_halfwidth"):
        make_job(**{"compute.reset_times": load})
    fast = make_job(**{"compute.reset_times": {**load, "method": "fast"}})
    assert fast.compute.reset_times.max_rel_halfwidth == 0.1
    assert fast.to_dict()["compute"]["reset_times"]["method"] == "fast"


@pytest.mark.slow
def test_reset_model_fit_writes_a_usable_model(tmp_path, capsys, pickplace):
    from dpfexplore.cli import main

    out = tmp_path / "tiny.json"
    code = main(
        [
            "reset-model",
            "fit",
            "--out",
            str(out),
            "--initial",
            "40",
            "--per-round",
            "10",
            "--rounds",
            "1",
            "--pool",
            "40",
            "--calibration",
            "40",
            "--test-designs",
            "0",
            "--json",
        ]
    )
    assert code == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out)
    assert record["training_designs"] == 50 and record["calibration_designs"] == 40
    # minutes of training are not silent: one line per stage on stderr
    stages = [line for line in captured.err.splitlines() if "reset-model fit:" in line]
    assert any("labelling 40" in s for s in stages) and any("calibrating" in s for s in stages)
    model = load_reset_model(out)
    assert isinstance(model, ResetModel) and math.isfinite(model.conformal_q)
    fast = reset_times_batch(
        DesignBatch.from_designs([pickplace]), PULSE, t_end=T_END, method="fast", model=out
    )
    np.testing.assert_allclose(fast["reset_time"][0, 4:6], PICKPLACE_RESETS, rtol=0.02)


@pytest.mark.slow
def test_bench_reset_model_record(capsys, tmp_path, monkeypatch):
    from dpfexplore.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["bench", "reset-model", "--json", "--designs", "4", "--save"]) == 0
    record = json.loads(capsys.readouterr().out)
    for key in (
        "us_per_design",
        "median_rel_err",
        "p95_rel_err",
        "max_rel_err",
        "class_agreement",
        "coverage_90",
        "fallback_rate",
    ):
        assert np.isfinite(record[key])
    assert record["pickplace"]["within_2pct"] is True
    assert (tmp_path / "results" / "reports" / "bench-reset-model.json").exists()
