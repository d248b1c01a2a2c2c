"""Surrogates of sweep outputs: split by design, exactness of neighbours on training points, the
training-range flag, held-out errors, save/load with fingerprints and versions, the CLI's one-line
errors. Data: small real sweeps (sequential states: several rows per design) in a tmp dir."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from sweep_helpers import make_job

from dpfexplore.cli import main
from dpfexplore.io.result_dirs import RESULT_MARKER
from dpfexplore.surrogates import store
from dpfexplore.surrogates.data import (
    held_out_errors,
    load_training_data,
    split_by_design,
)
from dpfexplore.surrogates.fit import fit_surrogates
from dpfexplore.surrogates.flat import DesignSurrogate, StatusClassifier
from dpfexplore.sweep.driver import run_sweep

OUTPUTS = ("tip_x", "tip_y", "stiffness")
SMALL = {"job.samples_per_n": 40, "compute.states": "sequential"}
FAST = {
    "gbt": {"max_iter": 30},
    "mlp": {"max_iter": 30, "hidden_layer_sizes": (16,)},
    "gp": {"max_train": 60},
    "classifier": {"max_iter": 30},
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("surrogate") / "sweep"
    run_sweep(make_job(**SMALL), root)
    return root


@pytest.fixture(scope="module")
def other_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("surrogate-other") / "sweep"
    run_sweep(make_job(**SMALL, **{"job.seed": 8}), root)
    return root


@pytest.fixture(scope="module")
def data(dataset):
    return load_training_data(dataset, OUTPUTS)


@pytest.fixture(scope="module")
def fitted(data):
    return fit_surrogates(
        data, kinds=["knn", "gbt", "mlp", "gp"], params=FAST, test_fraction=0.25, timing=False
    )


@pytest.fixture(scope="module")
def saved(fitted, tmp_path_factory):
    return store.save_surrogates(fitted, tmp_path_factory.mktemp("saved") / "model")


# ----------------------------------------------------------------------------- data and split


def test_training_data_reads_only_needed_columns(data):
    assert set(OUTPUTS) <= set(data.frame.columns)
    assert "energy" not in data.frame.columns and "curvature" not in data.frame.columns
    assert data.units == {"tip_x": "mm", "tip_y": "mm", "stiffness": "N/mm"}
    # several requested states per design: a row split could put one design on both sides
    assert data.frame.groupby("design_id").size().min() >= 3


def test_unknown_output_names_it(dataset):
    with pytest.raises(ValueError, match=r"output 'tip_z'.*choose from.*tip_x"):
        load_training_data(dataset, ["tip_x", "tip_z"])
    with pytest.raises(ValueError, match="output 'H_1'"):
        load_training_data(dataset, ["H_1"])


def test_split_by_design_keeps_every_design_on_one_side(data):
    ids = data.frame["design_id"].to_numpy()
    train, test = split_by_design(ids, test_fraction=0.25, seed=3)
    assert not (train & test).any() and (train | test).all()
    sides = pd.DataFrame({"id": ids, "test": test}).groupby("id")["test"].nunique()
    assert (sides == 1).all()
    assert np.unique(ids[test]).size == round(0.25 * np.unique(ids).size)
    capped, _ = split_by_design(ids, test_fraction=0.25, seed=3, max_train_designs=10)
    assert np.unique(ids[capped]).size == 10 and not (capped & test).any()


def _seen_rows(knn, frame):
    """Rows the neighbours model was fitted on: distance 0 to its training set."""
    n_units, scaled, _ = knn._features(frame)
    seen = np.zeros(len(frame), dtype=bool)
    for n, z in scaled.items():
        train_x = knn.models_[n]._fit_X
        dist = np.min(np.linalg.norm(z[:, None, :] - train_x[None, :, :], axis=2), axis=1)
        seen[n_units == n] = dist == 0.0
    return pd.DataFrame({"id": frame["design_id"].to_numpy(), "seen": seen})


def test_fitted_model_never_saw_a_held_out_row(data, fitted):
    """Under a split by design each design's rows are all seen in training or none is."""
    frame = data.frame[data.ok]
    per_design = _seen_rows(fitted.regressors["knn"], frame)
    mixed = per_design.groupby("id")["seen"].nunique() > 1
    assert not mixed.any()
    # control: the same check catches a split by row
    rows = np.random.default_rng(0).random(len(frame)) < 0.75
    by_row = DesignSurrogate(kind="knn").fit(frame[rows], frame.loc[rows, list(OUTPUTS)])
    assert (_seen_rows(by_row, frame).groupby("id")["seen"].nunique() > 1).any()
    # every design has ok rows (its flat state exists), so all held-out designs show up here
    held_out = (~per_design.groupby("id")["seen"].any()).sum()
    assert held_out == fitted.report["split"]["test_designs"]


# ----------------------------------------------------------------------------- estimators


def test_neighbours_model_is_exact_on_its_training_points(data):
    frame = data.frame[data.ok]
    y = frame[list(OUTPUTS)].to_numpy()
    model = DesignSurrogate(kind="knn").fit(frame, y)
    np.testing.assert_allclose(model.predict(frame), y, rtol=0, atol=1e-12)
    assert model.in_range(frame).all()


def test_out_of_range_rows_are_flagged(data):
    frame = data.frame[data.ok]
    model = DesignSurrogate(kind="knn").fit(frame, frame[list(OUTPUTS)].to_numpy())
    probe = frame.iloc[:4].copy()
    probe.loc[probe.index[0], "H_1"] = frame["H_1"].max() + 0.1  # outside the training box
    probe.loc[probe.index[1], "E"] = 40.0  # fixed in training at 26
    probe.loc[probe.index[2], "n_units"] = 5  # an N never fitted
    assert model.in_range(probe).tolist() == [False, False, False, True]
    assert np.isnan(model.predict(probe)[2]).all()
    assert np.isfinite(model.predict(probe)[[0, 1, 3]]).all()


def test_n_as_feature_fits_one_shared_model(data):
    frame = data.frame[data.ok]
    y = frame[list(OUTPUTS)].to_numpy()
    model = DesignSurrogate(kind="knn", per_n=False).fit(frame, y)
    assert list(model.models_) == [0]
    np.testing.assert_allclose(model.predict(frame), y, rtol=0, atol=1e-12)


def test_classifier_probabilities_and_validation(data):
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # OpenMP threads crawl on a loaded machine
        clf = StatusClassifier(kind="gbt", params={"max_iter": 20}).fit(data.frame, data.ok)
    proba = clf.predict_proba(data.frame)
    assert proba.shape == (len(data.frame), 2)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    with pytest.raises(ValueError, match="kind = 'knn'"):
        StatusClassifier(kind="knn").fit(data.frame, data.ok)
    with pytest.raises(ValueError, match="kind = 'tree'"):
        DesignSurrogate(kind="tree").fit(data.frame, np.zeros(len(data.frame)))


def test_held_out_errors_by_hand():
    frame = pd.DataFrame(
        {"n_units": [2, 2, 3, 3], "tip_x": [1.0, 2.0, 3.0, 4.0], "tip_y": [1.0, 1.0, 1.0, 1.0]}
    )
    offset = np.array([[0.3, 0.4], [0.3, 0.4], [0.6, 0.8], [0.0, 0.0]])
    pred = frame[["tip_x", "tip_y"]].to_numpy() + offset
    table = held_out_errors(frame, pred, ["tip_x", "tip_y"]).set_index(["output", "n_units"])
    assert table.loc[("tip", 2), "median"] == pytest.approx(0.5)
    assert table.loc[("tip", 3), "max"] == pytest.approx(1.0)
    assert table.loc[("tip", "all"), "median"] == pytest.approx(0.5)
    assert table.loc[("tip_x", 3), "median_rel"] == pytest.approx(0.1)


def test_report_compares_with_the_exact_model(fitted):
    report = fitted.report
    errors = pd.DataFrame(report["errors"])
    exact = errors[(errors["model"] == "exact") & (errors["output"] == "tip")]
    assert exact["max"].max() < 1e-9  # same designs as the dataset, same solver
    assert report["classifier"]["exact_model_agreement"] == 1.0
    assert set(report["kinds"]) == {"knn", "gbt", "mlp", "gp"}
    assert report["best"] in report["kinds"]
    assert report["split"]["by"] == "design_id"


def test_speed_table_and_verdict(data):
    s = fit_surrogates(data, kinds=["knn"], test_fraction=0.25, params=FAST)
    speed = {row["model"]: row for row in s.report["speed"]}
    assert {"knn", "exact"} <= set(speed)
    assert all(speed[m]["us_batched"] > 0 and speed[m]["us_single"] > 0 for m in speed)
    assert "exact model" in s.report["verdict"]


# ----------------------------------------------------------------------------- save and load


def test_save_load_round_trip(fitted, saved, data):
    loaded = store.load_surrogates(saved, dataset=data.root)
    frame = data.frame[data.ok]
    for kind, model in fitted.regressors.items():
        np.testing.assert_array_equal(loaded.regressors[kind].predict(frame), model.predict(frame))
    np.testing.assert_array_equal(
        loaded.classifier.predict_proba(frame), fitted.classifier.predict_proba(frame)
    )
    assert loaded.best == fitted.best and loaded.outputs == fitted.outputs
    assert loaded.report["split"] == json.loads(json.dumps(fitted.report["split"]))
    meta = json.loads((saved / store.META).read_text())
    assert meta["model_version"] and meta["versions"]["scikit-learn"]
    assert meta["dataset"]["fingerprint"]["chunks_sha256"] == data.fingerprint["chunks_sha256"]


def test_load_refuses_another_dataset(saved, other_dataset):
    with pytest.raises(store.SurrogateLoadError, match="not the one this surrogate was fitted on"):
        store.load_surrogates(saved, dataset=other_dataset)


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("model_version", "dpf-lattice-0", "model version 'dpf-lattice-0'"),
        ("surrogate_version", "surrogate-0", "surrogate version 'surrogate-0'"),
        ("versions.scikit-learn", "0.24.2", "scikit-learn 0.24.2"),
        ("models_sha256", "0" * 64, "checksum differs"),
        ("format", "other/9", "format 'other/9'"),
    ],
)
def test_load_refuses_mismatched_versions(saved, tmp_path, key, value, match):
    import shutil

    copy = shutil.copytree(saved, tmp_path / "model")
    # without its result manifest (a surrogate saved before them): the versions decide alone
    (copy / RESULT_MARKER).unlink()
    meta = json.loads((copy / store.META).read_text())
    *parents, last = key.split(".")
    target = meta
    for part in parents:
        target = target[part]
    target[last] = value
    (copy / store.META).write_text(json.dumps(meta))
    with pytest.raises(store.SurrogateLoadError, match=match):
        store.load_surrogates(copy)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda meta: [meta], "JSON object"),
        (lambda meta: {k: v for k, v in meta.items() if k != "outputs"}, "outputs"),
        (lambda meta: {**meta, "dataset": None}, "dataset"),
        (lambda meta: {**meta, "versions": "abc"}, "versions"),
    ],
)
def test_a_malformed_description_is_one_line(saved, tmp_path, edit, match):
    import shutil

    copy = shutil.copytree(saved, tmp_path / "model")
    (copy / RESULT_MARKER).unlink()
    meta = json.loads((copy / store.META).read_text())
    (copy / store.META).write_text(json.dumps(edit(meta)))
    for load in (store.load_surrogates, store.read_report):
        with pytest.raises(store.SurrogateLoadError, match=match) as info:
            load(copy)
        assert "\n" not in str(info.value)


def test_a_changed_file_of_a_saved_surrogate_is_refused(saved, tmp_path):
    import shutil

    copy = shutil.copytree(saved, tmp_path / "model")
    report = copy / store.REPORT
    report.write_text(report.read_text().replace("{", "{ ", 1))
    for load in (store.load_surrogates, store.read_report):
        with pytest.raises(store.SurrogateLoadError, match="changed after it was written"):
            load(copy)


def test_fractional_unit_counts_are_refused(saved, data):
    loaded = store.load_surrogates(saved)
    rows = data.frame[data.ok].head(3).copy()
    rows["n_units"] = rows["n_units"].astype(float)
    rows.iloc[1, rows.columns.get_loc("n_units")] = 3.7
    with pytest.raises(ValueError, match=r"n_units = 3\.7"):
        loaded.predict(rows)


# ----------------------------------------------------------------------------- CLI


def _one_line_error(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    return err


def test_cli_fit_report_predict(dataset, tmp_path, capsys):
    out = tmp_path / "cli-model"
    argv = [
        "surrogate",
        "fit",
        str(dataset),
        "--outputs",
        "tip_x,tip_y",
        "--out",
        str(out),
        "--kinds",
        "knn",
        "--no-timing",
    ]
    assert main(argv) == 0
    assert "held-out tip error" in capsys.readouterr().out
    assert main(["surrogate", "report", str(out)]) == 0
    assert "status classifier" in capsys.readouterr().out
    designs = pd.read_parquet(dataset).query("status_label == 'ok'").head(3).copy()
    designs.loc[designs.index[0], "t"] = 1.5  # outside the training box
    path = tmp_path / "designs.parquet"
    designs.to_parquet(path)
    assert main(["surrogate", "predict", str(out), str(path), "--dataset", str(dataset)]) == 0
    captured = capsys.readouterr()
    assert captured.out.count("OUT OF RANGE") == 1
    assert "1 of 3 designs lie outside the range" in captured.err
    written = tmp_path / "pred.csv"
    assert main(["surrogate", "predict", str(out), str(path), "--out", str(written)]) == 0
    table = pd.read_csv(written)
    assert table["in_range"].tolist() == [False, True, True]
    truth = designs[["tip_x", "tip_y"]].to_numpy()[1:]
    np.testing.assert_allclose(table[["tip_x", "tip_y"]].to_numpy()[1:], truth, atol=1e-12)


def test_cli_bad_input_one_line_exit_2(dataset, saved, other_dataset, tmp_path, capsys):
    err = _one_line_error(
        capsys,
        ["surrogate", "fit", str(dataset), "--outputs", "tip_q", "--out", str(tmp_path / "m")],
    )
    assert "output 'tip_q'" in err and not (tmp_path / "m").exists()
    err = _one_line_error(
        capsys,
        ["surrogate", "fit", str(tmp_path), "--outputs", "tip_x", "--out", str(tmp_path / "m")],
    )
    assert "not a sweep directory" in err
    err = _one_line_error(capsys, ["surrogate", "report", str(tmp_path / "missing")])
    assert "no saved surrogate" in err
    err = _one_line_error(
        capsys, ["surrogate", "predict", str(tmp_path / "missing"), str(tmp_path / "d.parquet")]
    )
    assert "no saved surrogate" in err
    text = tmp_path / "designs.parquet"
    text.write_text("n_units,H_1\n2,3.0\n")
    err = _one_line_error(capsys, ["surrogate", "predict", str(saved), str(text)])
    assert "not a Parquet file of designs" in err
    pd.DataFrame({"n_units": [2], "H_1": [3.5]}).to_parquet(tmp_path / "partial.parquet")
    err = _one_line_error(
        capsys, ["surrogate", "predict", str(saved), str(tmp_path / "partial.parquet")]
    )
    assert "missing column 'H_2'" in err
    err = _one_line_error(
        capsys, ["surrogate", "predict", str(saved), str(dataset), "--dataset", str(other_dataset)]
    )
    assert "not the one this surrogate was fitted on" in err
    err = _one_line_error(
        capsys, ["surrogate", "predict", str(saved), str(dataset), "--kind", "svm"]
    )
    assert "kind = 'svm'" in err


def test_a_dataset_of_another_set_is_fitted_and_checked_under_that_set(tmp_path):
    # The set's own physics throughout: the flat and chain estimators' dome features and rigid
    # units, and the exact model the report compares with (under the paper's set its tips
    # would be millimetres off these rows).
    from model_helpers import other_set

    from dpfexplore.surrogates.chain import ChainSurrogate
    from dpfexplore.surrogates.flat import _raw_features

    other_set().save(tmp_path / "other.json")
    root = tmp_path / "sweep"
    job = make_job(**SMALL, **{"job.constants": str(tmp_path / "other.json")})
    run_sweep(job, root)
    data = load_training_data(root, OUTPUTS)
    assert data.constants == other_set()
    fitted = fit_surrogates(
        data,
        kinds=["knn", "chain"],
        classifier_kind=["gbt", "chain"],
        params=FAST,
        test_fraction=0.25,
        timing=False,
    )
    errors = pd.DataFrame(fitted.report["errors"])
    exact = errors[(errors["model"] == "exact") & (errors["output"] == "tip")]
    assert exact["max"].max() < 1e-9
    assert fitted.report["classifier"]["exact_model_agreement"] == 1.0
    record = other_set().to_dict()
    knn, chain = fitted.regressors["knn"], fitted.regressors["chain"]
    assert knn.constants == record and isinstance(chain, ChainSurrogate)
    assert chain.constants == record and chain.inner_model_.constants == record
    assert all(c.constants == record for c in fitted.classifiers.values())
    rows = data.frame[data.frame["n_units"] == 2]
    raw, names = _raw_features(rows, 2, False, other_set())
    springs = other_set().springs(
        *(rows[c].to_numpy()[:, None] for c in ("H_1", "t", "r_b", "E", "U_sep_1", "t_ch"))
    )
    np.testing.assert_array_equal(raw[:, names.index("alpha_1")], springs["alpha"][:, 0])
    np.testing.assert_array_equal(raw[:, names.index("reach_1")], springs["d"][:, 0])
