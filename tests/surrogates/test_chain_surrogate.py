"""The chain surrogate: exact per-unit kinematics, the rigid unit-cell model against an
independently written energy, the split by design of unit rows, save/load, range flags, the
status rule against the exact model, and the CLI. Data: small real sweeps in a tmp dir."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sweep_helpers import make_job
from threadpoolctl import threadpool_limits

from dpfexplore.cli import main
from dpfexplore.model.domain import MAX_UNITS
from dpfexplore.solvers.statics import solve_batch
from dpfexplore.surrogates import store
from dpfexplore.surrogates.chain import (
    ChainStatusClassifier,
    ChainSurrogate,
    feature_names,
    unit_rows,
)
from dpfexplore.surrogates.chain_physics import (
    compose,
    rigid_units,
    state_bits,
    unit_kinematics,
)
from dpfexplore.surrogates.data import (
    designs_from_rows,
    held_out_errors,
    load_training_data,
    split_by_design,
)
from dpfexplore.surrogates.fit import fit_surrogates
from dpfexplore.sweep.driver import run_sweep

OUTPUTS = ("tip_x", "tip_y", "curvature", "stiffness")
#: Small and quick: a per-unit MLP of 32 x 32 (the residual it learns is smooth).
SMALL_MLP = {"hidden_layer_sizes": (32, 32), "max_iter": 150, "batch_size": 128}
FAST = {
    "chain": {**SMALL_MLP, "inner_params": {"max_iter": 30, "hidden_layer_sizes": (16,)}},
    "classifier": {"max_iter": 30},
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """All units inverted, N = 2..5, 90 designs each (about a third collapse)."""
    root = tmp_path_factory.mktemp("chain") / "sweep"
    run_sweep(make_job(**{"job.samples_per_n": 90, "space.n_units": [2, 3, 4, 5]}), root)
    return root


@pytest.fixture(scope="module")
def data(dataset):
    return load_training_data(dataset, OUTPUTS)


@pytest.fixture(scope="module")
def sequential(tmp_path_factory):
    """Sequential states (mixed inverted and flat units), N = 2..4."""
    root = tmp_path_factory.mktemp("chain-seq") / "sweep"
    run_sweep(
        make_job(
            **{"job.samples_per_n": 30, "space.n_units": [2, 3, 4], "compute.states": "sequential"}
        ),
        root,
    )
    return load_training_data(root, ("tip_x", "tip_y"))


@pytest.fixture(scope="module")
def split(data):
    return split_by_design(data.frame["design_id"].to_numpy(), test_fraction=0.25, seed=1)


@pytest.fixture(scope="module")
def chain(data, split):
    train = split[0] & data.ok
    frame = data.frame[train]
    with threadpool_limits(limits=1):
        return ChainSurrogate(
            outputs=OUTPUTS,
            params=SMALL_MLP,
            inner_params={"max_iter": 30, "hidden_layer_sizes": (16,)},
        ).fit(frame, frame[list(OUTPUTS)].to_numpy())


# ----------------------------------------------------------------------------- kinematics


def _exact(frame):
    batch = designs_from_rows(frame)
    out = solve_batch(
        batch, frame["requested"].to_numpy(), stiffness=False, min_eig=False, shapes=True
    )
    return batch, out


def test_exact_per_unit_quantities_compose_to_the_exact_tip(data, sequential):
    """rho, beta, ell read off exact shapes give back tip, bend angle and curvature to 1e-9."""
    frames = [data.frame[data.ok], sequential.frame[sequential.ok]]
    # and an 8-unit finger beyond the training N: the kinematics know no N
    eight = data.frame[data.ok & (data.frame["n_units"] == 5)].iloc[:3].copy()
    for k in (6, 7, 8):
        for name in ("H", "U_L", "U_sep"):
            eight[f"{name}_{k}"] = eight[f"{name}_{k - 3}"]
    eight["n_units"], eight["requested"] = 8, 255
    frames.append(eight)
    for frame in frames:
        batch, out = _exact(frame)
        found = out["status"] == 0
        assert found.all()
        p1 = batch.U_L[:, 0] + batch.t_ch + batch.U_sep[:, 0]
        h = 7.5 + batch.t_lim + batch.t  # MODEL.md §2: UC/2 + t_lim + t with r_b = 5
        rho, beta, ell = unit_kinematics(out["x"], batch.n_units, p1, h)
        composed = compose(rho, beta, ell, batch.n_units, h)
        for name in ("tip_x", "tip_y"):
            np.testing.assert_allclose(composed[name], out[name], rtol=0, atol=1e-9)
        np.testing.assert_allclose(composed["bend_angle"], out["bend_angle"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(composed["curvature"], out["curvature"], rtol=0, atol=1e-12)
        # the clamp: the first layer segment lies along +x at its rest length
        assert np.all(beta[:, 0] == 0.0)
        np.testing.assert_allclose(ell[:, 0], p1, rtol=1e-14)
        beyond = np.arange(MAX_UNITS)[None, :] >= batch.n_units[:, None]
        assert np.isnan(rho[beyond]).all()
    # an inverted unit turns its post counter-clockwise (the finger curls toward +y)
    batch, out = _exact(data.frame[data.ok])
    rho, _, _ = unit_kinematics(
        out["x"],
        batch.n_units,
        batch.U_L[:, 0] + 1 + batch.U_sep[:, 0],
        7.5 + batch.t_lim + batch.t,
    )
    inside = np.arange(MAX_UNITS)[None, :] < batch.n_units[:, None]
    assert np.median(rho[inside]) > 0.05


def test_unit_depends_on_itself_and_its_predecessor_only(data):
    """The locality the chain rests on: changing unit 3 leaves units 1, 2 (and 5) unchanged."""
    frame = data.frame[data.ok & (data.frame["n_units"] == 5)].iloc[:12].copy()
    changed = frame.copy()
    changed["H_3"] = np.where(frame["H_3"] > 4.0, frame["H_3"] - 0.8, frame["H_3"] + 0.8)
    quantities = []
    for rows in (frame, changed):
        batch, out = _exact(rows)
        p1 = batch.U_L[:, 0] + 1 + batch.U_sep[:, 0]
        quantities.append(
            (
                unit_kinematics(out["x"], batch.n_units, p1, 7.5 + batch.t_lim + batch.t),
                out["status"] == 0,
            )
        )
    (before, ok0), (after, ok1) = quantities
    both = ok0 & ok1
    assert both.sum() >= 6
    rho0, rho1 = before[0][both], after[0][both]
    change = np.abs(rho1 - rho0)
    assert np.all(change[:, :2] < 1e-5)  # units 1, 2: before the change
    assert np.median(change[:, 2]) > 1e-2  # unit 3 itself
    assert np.all(change[:, 3] < 1e-2)  # unit 4: through the shared post, small
    assert np.all(change[:, 4] < 1e-5)  # unit 5: two units on


# ----------------------------------------------------------------------------- rigid unit cell


def _rigid_energy(b, r, p, h, k_b, alpha, d, k_prev, k_own):
    """MODEL.md §4-§5 written out for one unit with rigid posts and an inextensible layer."""
    D = np.array([p * np.cos(b) + h * np.sin(r), h + p * np.sin(b) - h * np.cos(r)])
    x_bar = np.hypot(*D) - p
    u = x_bar / d
    dome = 0.5 * k_b * x_bar**2 * (1 + (1 - alpha) * (u * u - 2 * u))
    return dome + 0.5 * k_prev * b * b + 0.5 * k_own * (r - b) ** 2


def test_rigid_unit_model_is_a_minimum_of_the_independent_energy(data):
    """At every holding unit's solution the energy written out above has zero gradient and a
    positive definite Hessian (central differences): a local minimum on the inverted side."""
    frame = data.frame.iloc[:60]
    batch = designs_from_rows(frame)
    rigid = rigid_units(batch, state_bits(frame["requested"].to_numpy(), batch.n_units))
    checked = 0
    # Units whose dome cannot reach the next wall (d clamped to 0.01 mm) have an energy scale
    # too small for differences of this step.
    for i in np.flatnonzero(rigid.holds & rigid.inverted & (rigid.d > 0.1)):
        first = rigid.unit[i] == 0
        k_prev = 0.0 if first else rigid.k_t[i - 1]
        args = (
            rigid.p[i],
            rigid.h[i],
            rigid.k_b[i],
            rigid.alpha[i],
            rigid.d[i],
            k_prev,
            rigid.k_t[i],
        )
        energy = (
            (lambda v, a=args: _rigid_energy(0.0, v[0], *a))
            if first
            else (lambda v, a=args: _rigid_energy(v[0], v[1], *a))
        )
        x = np.array([rigid.rho[i]] if first else [rigid.beta[i], rigid.rho[i]])
        scale = rigid.k_b[i] * rigid.d[i] * rigid.h[i]
        # Small steps for the gradient (the dome's quartic energy has a large third
        # derivative), larger ones for the Hessian (rounding).
        steps = np.eye(x.size) * 1e-6
        grad = np.array([(energy(x + e) - energy(x - e)) / 2e-6 for e in steps])
        steps = np.eye(x.size) * 1e-4
        hess = np.array(
            [
                [
                    (energy(x + a + b) - energy(x + a - b) - energy(x - a + b) + energy(x - a - b))
                    / 4e-8
                    for b in steps
                ]
                for a in steps
            ]
        )
        assert np.abs(grad).max() < 1e-7 * scale
        assert np.linalg.eigvalsh(hess).min() > 0
        assert rigid.u[i] > 0.75  # past the fold of the isolated dome: inverted
        checked += 1
    assert checked >= 50
    # a dome with no inverted minimum of its own (alpha >= 1/9) cannot hold in its finger
    assert not np.any(rigid.holds & rigid.inverted & (rigid.alpha >= 1 / 9))
    # the margin's sign is the holding test of the linearised energy: it agrees with Newton
    inverted = rigid.inverted
    assert np.mean((rigid.margin[inverted] > 0) == rigid.holds[inverted]) > 0.99


def test_rigid_model_is_close_to_exact_and_the_learned_residual_closes_the_gap(data, split, chain):
    test = data.frame[split[1] & data.ok]
    truth = test[["tip_x", "tip_y"]].to_numpy()
    batch = designs_from_rows(test)
    rigid = rigid_units(batch, state_bits(test["requested"].to_numpy(), batch.n_units))
    alone = compose(
        np.nan_to_num(rigid.grid(rigid.rho)),
        np.nan_to_num(rigid.grid(np.where(rigid.unit == 0, 0.0, rigid.beta))),
        np.nan_to_num(rigid.grid(rigid.p)),
        batch.n_units,
        rigid.grid(rigid.h)[:, 0],
    )
    error_alone = np.hypot(alone["tip_x"] - truth[:, 0], alone["tip_y"] - truth[:, 1])
    predicted = chain.predict(test)
    error_chain = np.hypot(*(predicted[:, :2] - truth).T)
    # physics alone: a few hundredths of a mm; with the learned residual several times less
    assert 1e-3 < np.median(error_alone) < 0.1
    assert np.median(error_chain) < np.median(error_alone) / 3
    # outputs it does not compose come from its flat inner model
    assert chain.inner_model_ is not None and np.isfinite(predicted[:, 3]).all()


def test_chain_status_rule_agrees_with_the_exact_model(data, split):
    train, test = split
    clf = ChainStatusClassifier().fit(data.frame[train], data.ok[train])
    held = data.frame[test]
    predicted = clf.predict(held)
    assert np.mean(predicted == data.ok[test]) >= 0.98  # 99.985 % on 20,000 designs
    assert 0 < data.ok[test].mean() < 1  # both classes present
    proba = clf.predict_proba(held)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert np.array_equal(proba[:, 1] > 0.5, predicted)
    assert clf.slope_ > 0


# ----------------------------------------------------------------------------- split and range


def test_unit_rows_of_a_design_stay_on_its_side_of_the_split(data, split, chain):
    """Unit rows are built per design from the rows given to fit: a split by design of the
    design rows is a split by design of the unit rows."""
    train, test = split
    rows = {}
    for side, mask in (("train", train & data.ok), ("test", test & data.ok)):
        frame = data.frame[mask]
        batch = designs_from_rows(frame)
        rigid = rigid_units(batch, state_bits(frame["requested"].to_numpy(), batch.n_units))
        rows[side] = (unit_rows(rigid), frame["design_id"].to_numpy()[rigid.design], rigid)
    features, ids, rigid = rows["train"]
    assert features.shape[1] == len(feature_names())
    # the regressor was fitted on exactly the units of the training designs that hold
    assert chain.n_unit_rows_ == int(rigid.holds.sum())
    assert set(ids) == set(data.frame.loc[train & data.ok, "design_id"])
    # no unit row of a held-out design equals a training unit row
    test_features, test_ids, _ = rows["test"]
    assert not set(test_ids) & set(ids)
    train_keys = {row.tobytes() for row in features}
    assert not any(row.tobytes() in train_keys for row in test_features)
    # control: a random split of unit rows would put units of one design on both sides
    side = np.random.default_rng(0).random(ids.size) < 0.75
    mixed = pd.DataFrame({"id": ids, "side": side}).groupby("id")["side"].nunique() > 1
    assert mixed.any()


def test_out_of_range_rows_are_flagged(data, chain):
    frame = data.frame[data.ok]
    probe = frame[frame["n_units"] == 3].iloc[:5].copy()
    probe.loc[probe.index[0], "H_2"] = frame["H_2"].max() + 0.2  # outside the unit box
    probe.loc[probe.index[1], "E"] = 40.0  # fixed in training at 26
    probe.loc[probe.index[2], "t"] = 1.2  # outside the shared box
    probe.loc[probe.index[3], "requested"] = 0b101  # a flat unit: never seen
    assert chain.in_range(probe).tolist() == [False, False, False, False, True]
    # an N not among the training designs' is flagged, but still predicted (units are local)
    six = probe.iloc[[4]].copy()
    for k in (4, 5, 6):
        for name in ("H", "U_L", "U_sep"):
            six[f"{name}_{k}"] = six[f"{name}_{k - 3}"]
    six["n_units"], six["requested"] = 6, 63
    assert not chain.in_range(six)[0]
    assert np.isfinite(chain.predict(six)[0, :3]).all()
    clf = ChainStatusClassifier().fit(data.frame, data.ok)
    assert clf.in_range(probe).tolist() == [False, False, False, False, True]
    # without a 'requested' column: the all-inverted state it was fitted on
    bare = probe.drop(columns="requested").iloc[[4]]
    np.testing.assert_array_equal(chain.predict(bare), chain.predict(probe.iloc[[4]]))


def test_fit_refuses_rows_it_cannot_reproduce(data):
    frame = data.frame[data.ok].iloc[:30]
    y = frame[["tip_x", "tip_y"]].to_numpy().copy()
    y[3, 0] += 1e-3
    with pytest.raises(ValueError, match=r"tip_x differs from the exact model's by up to 0\.001"):
        ChainSurrogate(outputs=("tip_x", "tip_y"), params={"max_iter": 2}).fit(frame, y)
    collapsed = data.frame[~data.ok].iloc[:3]
    with pytest.raises(ValueError, match="3 rows whose requested state the exact model"):
        ChainSurrogate(outputs=("tip_x",), params={"max_iter": 2}).fit(
            collapsed, collapsed[["tip_x"]].to_numpy()
        )
    with pytest.raises(ValueError, match=r"y: shape \(30, 2\), need \(30, 1\)"):
        ChainSurrogate(outputs=("tip_x",)).fit(frame, y)


def test_mixed_states(sequential):
    """Sequential states: flat and inverted units side by side, with the requested sides."""
    frame = sequential.frame[sequential.ok]
    with threadpool_limits(limits=1):
        model = ChainSurrogate(outputs=("tip_x", "tip_y"), params=SMALL_MLP).fit(
            frame, frame[["tip_x", "tip_y"]].to_numpy()
        )
    assert model.sides_ == (0, 1) and model.in_range(frame).all()
    error = np.hypot(*(model.predict(frame) - frame[["tip_x", "tip_y"]].to_numpy()).T)
    assert np.median(error) < 0.05
    with pytest.raises(ValueError, match="missing column 'requested'"):
        model.predict(frame.drop(columns="requested"))


# ----------------------------------------------------------------------------- machinery


def test_fit_report_save_load_round_trip(data, tmp_path):
    fitted = fit_surrogates(
        data,
        kinds=["chain"],
        classifier_kind=["gbt", "chain"],
        params=FAST,
        test_fraction=0.25,
        seed=1,
    )
    report = fitted.report
    assert report["kinds"] == ["chain"] and report["best"] == "chain"
    assert [r["kind"] for r in report["classifiers"]] == ["gbt", "chain"]
    speed = {row["model"] for row in report["speed"]}
    assert {"chain", "classifier (gbt)", "classifier (chain)", "exact"} <= speed
    errors = pd.DataFrame(report["errors"])
    tip = errors[(errors["model"] == "chain") & (errors["output"] == "tip")]
    assert set(tip["n_units"]) == {2, 3, 4, 5, "all"}
    path = store.save_surrogates(fitted, tmp_path / "chain-model")
    loaded = store.load_surrogates(path, dataset=data.root)
    frame = data.frame
    np.testing.assert_array_equal(
        loaded.regressors["chain"].predict(frame), fitted.regressors["chain"].predict(frame)
    )
    for kind in ("gbt", "chain"):
        np.testing.assert_array_equal(
            loaded.classifiers[kind].predict_proba(frame),
            fitted.classifiers[kind].predict_proba(frame),
        )
    assert type(loaded.classifier) is type(fitted.classifier)
    pd.testing.assert_frame_equal(loaded.predict(frame), fitted.predict(frame))
    # the held-out table is the one held_out_errors gives for these predictions
    test = data.frame[
        split_by_design(data.frame["design_id"].to_numpy(), test_fraction=0.25, seed=1)[1] & data.ok
    ]
    table = held_out_errors(test, fitted.regressors["chain"].predict(test), list(OUTPUTS))
    mine = table[(table["output"] == "tip") & (table["n_units"] == "all")]
    assert mine["median"].iloc[0] == pytest.approx(tip[tip["n_units"] == "all"]["median"].iloc[0])


def test_cli_fits_the_chain_and_rejects_an_unknown_classifier(dataset, tmp_path, capsys):
    out = tmp_path / "cli-chain"
    argv = [
        "surrogate",
        "fit",
        str(dataset),
        "--outputs",
        "tip_x,tip_y",
        "--out",
        str(out),
        "--kinds",
        "chain",
        "--classifier",
        "chain",
        "--no-timing",
        "--params",
        '{"chain": {"hidden_layer_sizes": [16], "max_iter": 20}}',
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "status classifier (chain) (used)" in text and "chain" in text
    bad = [
        "surrogate",
        "fit",
        str(dataset),
        "--outputs",
        "tip_x,tip_y",
        "--out",
        str(tmp_path / "m2"),
        "--kinds",
        "chain",
        "--classifier",
        "chain,svm",
    ]
    assert main(bad) == 2 and not (tmp_path / "m2").exists()
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "classifier kind 'svm'" in err


def test_the_chain_solves_its_rigid_units_under_its_constants_set(data):
    """Issue 20: a chain surrogate fitted on a dataset of another set keeps that set (as its
    JSON form, an estimator parameter) and solves its rigid units under it."""
    from model_helpers import other_set

    from dpfexplore.model.constants_set import DEFAULT
    from dpfexplore.surrogates.chain import _designs

    assert data.constants == DEFAULT
    rows = data.frame[data.ok].head(20)
    paper, _ = _designs(rows, None, None)
    other, bits = _designs(rows, None, other_set().to_dict())
    assert paper.constants == DEFAULT and other.constants == other_set()
    a, b = rigid_units(paper, bits.astype(bool)), rigid_units(other, bits.astype(bool))
    assert not np.allclose(a.u, b.u, equal_nan=True)
    estimator = ChainStatusClassifier(constants=other_set().to_dict())
    assert estimator.get_params()["constants"]["name"] == "other"
