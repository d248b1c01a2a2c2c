"""Commands that write result directories: refuse another run's directory without --force,
replace it whole with --force (no file of the earlier run survives), check --out before the work.
"""

from __future__ import annotations

import time

from dpfexplore.cli import main
from dpfexplore.io.result_dirs import verify_result_dir

SCENE = """
[scene]
kind = "position"
name = "small"
material = "cheetah-95a"
seed = 1

[variables]
n_units = 2
H = {min = 3.0, max = 5.0}
U_L = {min = 5.5, max = 10.0}
U_sep = {min = 1.0, max = 5.0}
t = {min = 0.5, max = 1.0}
t_lim = {min = 1.0, max = 2.0}

[objective]
tolerance = 0.01

[optimiser]
candidates_per_n = 8
starts_per_n = 1
max_iter = 15
"""


def scene(tmp_path, n_targets: int):
    targets = "".join(
        f"\n[[targets]]\npoint = [{40.0 + 2 * i}, {20.0 + i}]\n" for i in range(n_targets)
    )
    path = tmp_path / f"scene-{n_targets}.toml"
    path.write_text(SCENE + targets)
    return path


def test_design_refuses_another_run_and_force_replaces_it_whole(tmp_path, capsys):
    out = tmp_path / "out"
    main(["design", str(scene(tmp_path, 3)), "--out", str(out), "--json"])
    assert sorted(p.name for p in out.glob("target-*.toml")) == [
        "target-01.toml",
        "target-02.toml",
        "target-03.toml",
    ]
    verify_result_dir(out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()

    started = time.perf_counter()
    assert main(["design", str(scene(tmp_path, 1)), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "--force" in err and str(out) in err and "a design result" in err and "\n" not in err
    assert time.perf_counter() - started < 10  # refused before solving
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before

    main(["design", str(scene(tmp_path, 1)), "--out", str(out), "--force", "--json"])
    assert sorted(p.name for p in out.glob("target-*.toml")) == ["target-01.toml"]
    verify_result_dir(out)


def test_design_into_a_sweep_dataset_or_the_working_directory_is_refused(
    tmp_path, capsys, monkeypatch
):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "_manifest.json").write_text("{}")
    assert main(["design", str(scene(tmp_path, 1)), "--out", str(sweep), "--force"]) == 2
    assert "sweep dataset" in capsys.readouterr().err
    monkeypatch.chdir(tmp_path)
    assert main(["design", str(scene(tmp_path, 1)), "--out", ".", "--force"]) == 2
    assert main(["design", str(scene(tmp_path, 1)), "--out", "", "--force"]) == 2
    assert (sweep / "_manifest.json").read_text() == "{}"


def test_lookup_write_is_a_result_directory(tmp_path, capsys):
    from sweep_helpers import job_dict, toml_text

    job = tmp_path / "job.toml"
    job.write_text(toml_text(job_dict(**{"job.samples_per_n": 30, "space.n_units": [3]})))
    assert main(["sweep", str(job), "--out", str(tmp_path / "d")]) == 0
    out = tmp_path / "candidates"
    base = ["lookup", str(tmp_path / "d"), "--target", "40,30", "--write", str(out)]
    assert main([*base, "--k", "3"]) == 0
    assert len(list(out.glob("candidate-*.toml"))) == 3
    verify_result_dir(out)
    capsys.readouterr()
    assert main([*base, "--k", "1"]) == 2
    assert "--force" in capsys.readouterr().err
    assert main([*base, "--k", "1", "--force"]) == 0
    assert [p.name for p in out.glob("candidate-*.toml")] == ["candidate-01.toml"]
    assert main(["states", str(out / "candidate-01.toml")]) == 0


def test_reset_maps_and_surrogate_fit_refuse_before_the_work(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    started = time.perf_counter()
    assert main(["reset-maps", "--quick", "--out", str(taken)]) == 2
    fit = ["surrogate", "fit", str(tmp_path), "--outputs", "tip_x", "--out", str(taken)]
    assert main(fit) == 2
    assert time.perf_counter() - started < 10
    err = capsys.readouterr().err
    assert err.count("--force") == 2
    assert (taken / "notes.txt").read_text() == "mine"


def test_reset_maps_default_out_is_a_folder_of_its_own(tmp_path, capsys, monkeypatch):
    import pandas as pd
    from matplotlib.figure import Figure

    from dpfexplore.plotting import dynamics
    from dpfexplore.solvers.dynamics import resetmaps

    # the simulations are not what is tested here: three tiny maps stand in for them
    frame = pd.DataFrame({"value": [1.0, 2.0], "reset_time": [0.1, 0.2], "status": ["ok"] * 2})
    maps = {name: frame for name in ("H", "t", "hold")}
    monkeypatch.setattr(resetmaps, "reset_time_maps", lambda spec: maps)
    monkeypatch.setattr(dynamics, "plot_reset_maps", lambda maps: Figure(figsize=(1, 1)))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "notes.txt").write_text("mine")  # results/ is shared, not replaced
    assert main(["reset-maps", "--quick"]) == 0
    out = tmp_path / "results" / "reset-maps"
    assert verify_result_dir(out)["kind"] == "reset-maps"
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "reset_map_H.parquet",
        "reset_map_hold.parquet",
        "reset_map_t.parquet",
        "reset_maps.png",
    ]
    assert (tmp_path / "results" / "notes.txt").read_text() == "mine"
    capsys.readouterr()
    assert main(["reset-maps", "--quick"]) == 2
    assert "a reset-maps result" in capsys.readouterr().err
    assert main(["reset-maps", "--quick", "--force"]) == 0
    verify_result_dir(out)
