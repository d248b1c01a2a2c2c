"""``dpfexplore sweep | query | plot-space`` through ``main([...])``: exit codes, one-line errors,
nothing written on bad input, query output, the design-space figure."""

from __future__ import annotations

import io
import json
import shutil
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
from plotting.figure_checks import assert_readable
from sweep_helpers import job_dict, toml_text

from dpfexplore.cli import main
from dpfexplore.sweep.storage import store

matplotlib.use("Agg")

JOBS = Path(__file__).parents[2] / "jobs"
SMALL = {"job.name": "cli", "job.samples_per_n": 24, "compute.states": "sequential"}


def write_job(path: Path, **changes) -> Path:
    path.write_text(toml_text(job_dict(**{**SMALL, **changes})))
    return path


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    job = write_job(root / "job.toml")
    assert main(["sweep", str(job), "--out", str(root / "out"), "--chunk-size", "10"]) == 0
    return root


def test_sweep_prints_summary_and_log_lines(tmp_path, capsys):
    job = write_job(tmp_path / "job.toml")
    assert main(["sweep", str(job), "--out", str(tmp_path / "out")]) == 0
    captured = capsys.readouterr()
    assert "sweep cli: 48 designs (48 computed now" in captured.out
    assert "statuses:" in captured.out
    # not a terminal: log lines with rate and ETA instead of a bar
    assert "designs/s" in captured.err and "ETA" in captured.err
    # what happens before the first chunk: a first compilation says so, a cached one loads
    assert (
        "compiling the statics kernels" in captured.err
        or "loading the compiled kernels" in captured.err
    )
    assert store.read_manifest(tmp_path / "out").complete


def test_default_output_directory_is_results_job_name(tmp_path, monkeypatch):
    job = write_job(tmp_path / "job.toml", **{"job.samples_per_n": 3})
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(job)]) == 0
    assert store.read_manifest(tmp_path / "results" / "cli").complete


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"job.colour": "red"}, "job.colour"),
        ({"space.variables.t": "__delete__"}, "space.variables.t"),
        ({"space.variables.H": {"min": 5.0, "max": 3.0}}, "space.variables.H.min"),
        ({"space.variables.U_sep": {"min": "a", "max": 3.0}}, "space.variables.U_sep.min"),
        ({"space.n_units": [2, 14]}, "space.n_units"),
    ],
)
def test_bad_job_exit_2_one_line_nothing_written(tmp_path, capsys, changes, key):
    data = job_dict(**SMALL)
    for dotted, value in changes.items():
        *parents, last = dotted.split(".")
        table = data
        for part in parents:
            table = table[part]
        if value == "__delete__":
            del table[last]
        else:
            table[last] = value
    job = tmp_path / "bad.toml"
    job.write_text(toml_text(data))
    out = tmp_path / "out"
    assert main(["sweep", str(job), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"bad.toml: {key}" in err
    assert not out.exists()


def test_another_jobs_directory_exit_2(swept, tmp_path, capsys):
    before = sorted((p.name, p.stat().st_mtime_ns) for p in (swept / "out").rglob("*"))
    other = write_job(tmp_path / "other.toml", **{"job.seed": 99})
    assert main(["sweep", str(other), "--out", str(swept / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "job.seed differs" in err
    assert sorted((p.name, p.stat().st_mtime_ns) for p in (swept / "out").rglob("*")) == before


def test_bad_flags_exit_2(swept, tmp_path, capsys):
    job = write_job(tmp_path / "job.toml")
    out = tmp_path / "out"
    assert main(["sweep", str(job), "--out", str(out), "--scheduler", "tcp://x:1"]) == 2
    assert main(["sweep", str(job), "--out", str(out), "--chunk-size", "0"]) == 2
    assert main(["sweep", str(job), "--out", str(out), "--workers", "0"]) == 2
    assert not out.exists()
    assert main(["sweep", str(tmp_path / "missing.toml")]) == 2
    assert "no such job file" in capsys.readouterr().err


def test_query_json_csv_columns(swept, capsys, tmp_path):
    out = str(swept / "out")
    where = "n_units == 3 and status == 0 and curvature > 0.004"
    assert (
        main(
            [
                "query",
                out,
                "--where",
                where,
                "--columns",
                "design_id,requested_bits",
                "curvature",
                "--json",
            ]
        )
        == 0
    )
    records = json.loads(capsys.readouterr().out)
    expected = store.read_results(out).query(where)
    assert len(records) == len(expected) > 0
    assert set(records[0]) == {"design_id", "requested_bits", "curvature"}
    np.testing.assert_allclose([r["curvature"] for r in records], expected["curvature"])

    csv = tmp_path / "rows.csv"
    assert main(["query", out, "--where", where, "--csv", str(csv)]) == 0
    frame = pd.read_csv(csv)
    assert len(frame) == len(expected)
    np.testing.assert_allclose(frame["tip_y"], expected["tip_y"], rtol=1e-15)

    assert main(["query", out, "--where", "n_units == 2", "--columns", "tip_x"]) == 0
    text = capsys.readouterr().out
    assert "tip_x" in text and "rows)" in text

    assert main(["query", out, "--csv", "-", "--columns", "design_id"]) == 0
    assert len(pd.read_csv(io.StringIO(capsys.readouterr().out))) == len(store.read_results(out))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--where", "n_units =="], "--where"),
        (["--where", "no_such_column > 1"], "--where"),
        (["--columns", "nope"], "--columns"),
    ],
)
def test_query_bad_input_exit_2(swept, capsys, args, message):
    assert main(["query", str(swept / "out"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err


def test_query_not_a_sweep_exit_2(tmp_path, capsys):
    assert main(["query", str(tmp_path)]) == 2
    assert "not a sweep directory" in capsys.readouterr().err


def test_plot_space_writes_the_figure_outside_the_dataset(swept, tmp_path):
    # plot-space needs all-inverted rows: a copy of the sweep is enough (sequential states
    # include the all-inverted one).
    data = tmp_path / "data"
    shutil.copytree(swept / "out", data)
    assert main(["plot-space", str(data)]) == 0
    image = tmp_path / "data.png"
    assert image.stat().st_size > 10_000
    assert image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the dataset directory stays a clean Parquet dataset
    assert len(pd.read_parquet(data)) == store.read_manifest(data).n_rows


def test_plotting_functions_draw_the_converged_all_inverted_rows(swept):
    import matplotlib.pyplot as plt

    from dpfexplore.plotting.space import all_inverted_rows, plot_design_space

    frame = store.read_results(swept / "out")
    rows = all_inverted_rows(frame)
    assert (rows["requested"] == 2 ** rows["n_units"].astype(int) - 1).all()
    assert (rows["status"] == 0).all() and len(rows) > 0
    axes = plot_design_space(frame)
    assert len(axes) == 3
    drawn = sum(len(c.get_offsets()) for c in axes[0].collections)
    assert drawn == len(rows)
    assert axes[2].get_ylabel().startswith("log10 stiffness")
    assert_readable(axes[0].figure)  # the figure plot-space saves
    plt.close(axes[0].figure)
    with pytest.raises(ValueError, match="stiffness"):
        from dpfexplore.plotting.space import plot_stiffness

        plot_stiffness(frame.drop(columns="stiffness"))


@pytest.mark.slow
def test_smoke_job_dask_engine_equals_local(tmp_path, capsys):
    # The shipped smoke job (sequential states, stiffness, min_eig, reset times) through the CLI,
    # on a LocalCluster of 2 worker processes that the engine starts and with another chunk
    # size, against the local engine.
    local, dask = tmp_path / "local", tmp_path / "dask"
    assert main(["sweep", str(JOBS / "smoke.toml"), "--out", str(local)]) == 0
    assert (
        main(
            [
                "sweep",
                str(JOBS / "smoke.toml"),
                "--out",
                str(dask),
                "--engine",
                "dask",
                "--workers",
                "2",
                "--chunk-size",
                "7",
            ]
        )
        == 0
    )
    assert "engine dask" in capsys.readouterr().out
    key = ["design_id", "requested"]
    a = store.read_results(local).sort_values(key).reset_index(drop=True)
    b = store.read_results(dask).sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b)
    assert (a["dyn_status_label"] == "ok").any()  # some designs were simulated
    # reset times and unit classes agree (MODEL.md §8): inf = bistable (0), finite >= 0.05 s =
    # metastable (1), sooner = monostable (2), none = never inverted or no contact (-1, 3);
    # unit 1 of this job has all three kinds
    for k in range(1, 5):
        reset, cls = a[f"reset_time_{k}"].to_numpy(), a[f"unit_class_{k}"].to_numpy()
        simulated = ~np.isnan(cls)
        assert (np.isinf(reset[simulated]) == (cls[simulated] == 0)).all()
        with np.errstate(invalid="ignore"):
            assert ((np.isfinite(reset) & (reset >= 0.05)) == (cls == 1)).all()
            assert ((np.isfinite(reset) & (reset < 0.05)) == (cls == 2)).all()
        assert np.isin(cls[simulated & np.isnan(reset)], [-1, 3]).all()
    kinds = set(a["unit_class_1"].dropna().astype(int))
    assert {0, 1, 2} <= kinds
    # the dynamics of a design do not depend on the state row it is reported on
    per_design = a.groupby("design_id")["reset_time_1"].nunique(dropna=False)
    assert (per_design == 1).all()
