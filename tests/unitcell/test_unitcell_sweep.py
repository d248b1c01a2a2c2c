"""``unitcell sweep``: jobs, chunks written whole, resume, failures as rows, the identify table."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from dpfexplore.cli import main
from dpfexplore.identification.curves import read_curves
from dpfexplore.unitcell.sweep import job_from_dict, read_job, run_unitcell_sweep

GRID = {
    "grid": {"H": [3.0], "t": [0.8, 6.0], "r_b": 5.0},  # t = 6 > r_b: invalid, a row not a crash
    "options": {"n_elements": 32, "chunk": 1},
}


def test_grid_sweep_resumes_and_keeps_failures_as_rows(tmp_path):
    job = job_from_dict(GRID)
    assert job.geometries.shape == (2, 5)
    manifest = run_unitcell_sweep(job, tmp_path / "sw")
    assert manifest["status"] == {"reached": 1, "invalid": 1}
    designs = pd.read_parquet(tmp_path / "sw" / "designs.parquet")
    assert list(designs["status"]) == ["reached", "invalid"]
    assert designs["message"][1].startswith("t=6.0")
    (curve,) = read_curves(tmp_path / "sw" / "curves.parquet")
    assert curve.folded and curve.tip_dis == pytest.approx(designs["tip_dis"][0])
    # a second run finds every chunk committed and recomputes nothing
    (tmp_path / "sw" / "curves.parquet").unlink()
    seen = []
    run_unitcell_sweep(job, tmp_path / "sw", progress=lambda done, total: seen.append(done))
    assert seen == [] and (tmp_path / "sw" / "curves.parquet").exists()
    other = job_from_dict({**GRID, "options": {"n_elements": 48, "chunk": 1}})
    with pytest.raises(ValueError, match="another job"):
        run_unitcell_sweep(other, tmp_path / "sw")


def test_latin_hypercube_is_scaled_into_its_bounds():
    job = job_from_dict({"lhs": {"n": 20, "seed": 0, "H": [1.0, 5.0], "t": [0.3, 1.2]}})
    H, t, r_b, E, nu = job.geometries.T
    assert np.all((H >= 1.0) & (H <= 5.0)) and np.all((t >= 0.3) & (t <= 1.2))
    assert np.all(r_b == 5.0) and np.all(E == 26.0) and np.all(nu == 0.35)
    # stratified: one point in each of the 20 strata of every varied parameter
    assert sorted(np.floor((H - 1.0) / 4.0 * 20).astype(int)) == list(range(20))


@pytest.mark.parametrize(
    "source, match",
    [
        ({}, "exactly one"),
        ({"grid": {"H": [3.0], "t": "x"}}, r"grid\.t = "),
        ({"grid": {"H": [3.0]}}, r"grid\.t: missing"),
        ({"lhs": {"n": 0, "H": [1, 2], "t": [0.5, 1]}}, r"lhs\.n = "),
        ({"lhs": {"n": 5, "H": [2, 1], "t": [0.5, 1]}}, r"lhs\.H = "),
        ({"grid": {"H": [3.0], "t": [1.0]}, "options": {"steps": 3}}, r"options\.steps"),
        ({"grid": {"H": [3.0], "t": [1.0]}, "extra": {}}, r"extra = \{\.\.\.\}: unknown key"),
    ],
)
def test_bad_jobs_name_the_entry(source, match):
    with pytest.raises(ValueError, match=match):
        job_from_dict(source)


def test_cli_sweep_on_two_workers(tmp_path, capsys):
    job = tmp_path / "job.toml"
    job.write_text("[grid]\nH = [3.0, 4.0]\nt = [1.0]\n[options]\nn_elements = 32\nchunk = 1\n")
    code = main(
        ["unitcell", "sweep", str(job), "--out", str(tmp_path / "sw"), "--workers", "2", "--json"]
    )
    manifest = json.loads(capsys.readouterr().out)
    assert code == 0 and manifest["status"] == {"reached": 2}
    assert len(read_curves(tmp_path / "sw" / "curves.parquet")) == 2
    assert read_job(job).options["n_elements"] == 32
    assert main(["unitcell", "sweep", str(tmp_path / "none.toml"), "--out", str(tmp_path)]) == 2


def test_a_dask_cluster_traces_the_same_curves_as_this_process(tmp_path):
    """A real LocalCluster of two worker processes: the chunks come back whole and equal."""
    job = job_from_dict(
        {"grid": {"H": [3.0, 4.0], "t": [0.8]}, "options": {"n_elements": 32, "chunk": 1}}
    )
    here = run_unitcell_sweep(job, tmp_path / "here")
    there = run_unitcell_sweep(job, tmp_path / "there", workers=2, engine="dask")
    assert here["status"] == there["status"] == {"reached": 2}
    a = pd.read_parquet(tmp_path / "here" / "curves.parquet")
    b = pd.read_parquet(tmp_path / "there" / "curves.parquet")
    pd.testing.assert_frame_equal(a, b)
    with pytest.raises(ValueError, match="engine"):
        run_unitcell_sweep(job, tmp_path / "x", engine="ray")


def test_the_cell_tip_option_takes_tip_dis_from_the_dome_in_its_plate(tmp_path):
    from dpfexplore.unitcell import unit_cell_curve
    from dpfexplore.unitcell.geometry import cell_plate

    source = {"grid": {"H": [4.0], "t": [0.75]}, "options": {"n_elements": 48, "tip": "cell"}}
    job = job_from_dict(source)
    assert job.options["tip"] == "cell"
    # a job without the option keeps its fingerprint (the option is recorded only when given)
    plain = job_from_dict({"grid": {"H": [4.0], "t": [0.75]}, "options": {"n_elements": 48}})
    assert "tip" not in plain.options
    run_unitcell_sweep(job, tmp_path / "sw")
    designs = pd.read_parquet(tmp_path / "sw" / "designs.parquet")
    cell = unit_cell_curve(4.0, 0.75, plate=cell_plate(5.0), n_elements=48)
    assert designs["tip_dis"][0] == pytest.approx(cell.tip_dis, rel=1e-9)
    assert designs["tip_kind"][0] == "rest" and designs["cell_status"][0] == "reached"
    assert designs["cap_tip_dis"][0] < designs["tip_dis"][0]  # the plate lets it reach further
    (curve,) = read_curves(tmp_path / "sw" / "curves.parquet")
    assert curve.tip_dis == pytest.approx(cell.tip_dis, rel=1e-9)
    with pytest.raises(ValueError, match=r"options\.tip = 'wall': must be one of cap, cell"):
        job_from_dict({**source, "options": {"tip": "wall"}})
