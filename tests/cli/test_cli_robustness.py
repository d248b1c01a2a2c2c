"""The CLI never answers with a traceback: interrupts, closed pipes, missing folders, bad paths,
reruns; and it says when it compiles."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import spy
from sweep_helpers import job_dict, toml_text

from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.model.design import DesignBatch
from dpfexplore.sweep.storage import store

SMALL = {"job.name": "cli", "job.samples_per_n": 24, "compute.states": "sequential"}
# The real command with every chunk slowed down, so that a signal lands mid-sweep.
SLOW_CLI = """
import signal, sys, time
# A shell starts background jobs with SIGINT ignored, and Python then installs no handler: a
# test run in the background would see the sweep ignore Ctrl-C. Restore what a terminal gives.
signal.signal(signal.SIGINT, signal.default_int_handler)
from dpfexplore.sweep import evaluation
call = evaluation.StaticsEvaluator.__call__
def slow(self, batch):
    time.sleep(0.2)
    return call(self, batch)
evaluation.StaticsEvaluator.__call__ = slow
from dpfexplore.cli import main
sys.exit(main(sys.argv[1:]))
"""


def write_job(path: Path, **changes) -> Path:
    path.write_text(toml_text(job_dict(**{**SMALL, **changes})))
    return path


def committed(out: Path) -> int:
    try:
        return len(json.loads((out / store.MANIFEST).read_text())["chunks"])
    except (FileNotFoundError, ValueError, KeyError):
        return 0


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    root = tmp_path_factory.mktemp("robust")
    job = write_job(root / "job.toml")
    assert main(["sweep", str(job), "--out", str(root / "out"), "--chunk-size", "6"]) == 0
    return root


@pytest.mark.slow
def test_ctrl_c_ends_a_sweep_with_one_line_and_exit_130(tmp_path):
    job = write_job(tmp_path / "job.toml", **{"job.samples_per_n": 120})
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        SLOW_CLI,
        "sweep",
        str(job),
        "--out",
        str(out),
        "--chunk-size",
        "10",
    ]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while committed(out) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and stdout == ""
    last = stderr.strip().splitlines()[-1]
    done = committed(out)
    assert last == (
        f"dpfexplore sweep: interrupted; {done} of 24 chunks ({10 * done} of 240 designs) are "
        f"committed in {out}; continue with: dpfexplore sweep {job} --out {out} --resume"
    )
    assert not (out / ".dpfexplore-lock").exists()
    assert main(["sweep", str(job), "--out", str(out), "--resume"]) == 0
    assert store.read_manifest(out).complete


@pytest.mark.slow
def test_a_closed_stderr_does_not_stop_a_sweep(tmp_path):
    job = write_job(tmp_path / "job.toml")
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-m",
        "dpfexplore",
        "-v",
        "sweep",
        str(job),
        "--out",
        str(out),
        "--chunk-size",
        "4",
    ]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stderr.close()  # every progress and log line now meets a broken pipe
    stdout = proc.stdout.read()
    proc.wait(timeout=300)
    assert proc.returncode == 0, stdout
    assert "sweep cli: 48 designs (48 computed now" in stdout
    assert store.read_manifest(out).complete


@pytest.mark.slow
def test_query_json_into_a_closed_pipe_is_quiet(swept):
    command = [sys.executable, "-m", "dpfexplore", "query", str(swept / "out"), "--json"]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # like `| head` that has read enough
    stderr = proc.stderr.read().decode()
    proc.wait(timeout=300)
    assert proc.returncode == 0 and stderr == "", stderr


def test_simulate_on_a_directory_is_one_line(tmp_path, capsys):
    assert main(["simulate", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"dpfexplore simulate: error: {tmp_path}: is a directory, not a design file (TOML)"
    ]


def test_every_output_file_gets_its_folder(swept, tmp_path, capsys, monkeypatch):
    import matplotlib.pyplot as plt

    import dpfexplore.plotting.space as space_plots
    import dpfexplore.plotting.statics as state_plots

    states_drawn = spy(monkeypatch, state_plots, "plot_states")
    space_drawn = spy(monkeypatch, space_plots, "plot_design_space")
    plot = tmp_path / "a" / "states.png"
    assert (
        main(["states", str(example_path("pickplace")), "--sequential", "--plot", str(plot)]) == 0
    )
    csv = tmp_path / "b" / "c" / "rows.csv"
    assert main(["query", str(swept / "out"), "--columns", "design_id", "--csv", str(csv)]) == 0
    png = tmp_path / "d" / "space.png"
    assert main(["plot-space", str(swept / "out"), "--out", str(png)]) == 0
    capsys.readouterr()
    assert plot.read_bytes()[:4] == b"\x89PNG" and png.read_bytes()[:4] == b"\x89PNG"
    # what the figures show: the five stable sequential states of the pick-and-place finger
    # (limiting layers drawn solid, 2 pt), and one point per converged all-inverted row
    (ax,) = states_drawn
    layers = [line.get_label() for line in ax.get_lines() if line.get_linewidth() == 2.0]
    assert layers == ["000000", "100000", "110000", "111000", "111100"]
    (axes,) = space_drawn
    rows = space_plots.all_inverted_rows(store.read_results(swept / "out"))
    assert len(axes) == 3 and len(rows) > 0
    assert sum(len(c.get_offsets()) for c in axes[0].collections) == len(rows)
    assert axes[0].get_xlabel() == "tip x (mm)" and axes[0].get_ylabel() == "tip y (mm)"
    plt.close(ax.figure)
    plt.close(axes[0].figure)
    assert csv.read_text().startswith("design_id\n")


def test_messages_print_numbers_as_numbers():
    batch = DesignBatch(
        n_units=np.array([2]),
        H=np.pad([[4.0, 4.0]], ((0, 0), (0, 10)), constant_values=np.nan),
        U_L=np.pad([[8.0, 8.0]], ((0, 0), (0, 10)), constant_values=np.nan),
        U_sep=np.pad([[1.0, 1.0]], ((0, 0), (0, 10)), constant_values=np.nan),
        t=np.array([-0.83]),
        t_lim=np.array([1.0]),
        E=26.0,
        nu=0.35,
        r_b=5.0,
        t_ch=1.0,
    )
    message = batch.problems()[1][0]
    assert message == "t = -0.83: must be finite and > 0 mm"


def test_a_rerun_of_a_complete_sweep_prints_its_summary(swept, capsys):
    job, out = swept / "job.toml", swept / "out"
    assert main(["sweep", str(job), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "sweep cli: 48 designs (0 computed now, 8 of 8 chunks reused)" in said
    assert "statuses:" in said


def test_a_rerun_of_an_incomplete_sweep_asks_for_resume(tmp_path, capsys):
    job = write_job(tmp_path / "job.toml")
    out = tmp_path / "out"
    assert main(["sweep", str(job), "--out", str(out), "--chunk-size", "6"]) == 0
    manifest = store.read_manifest(out)
    manifest.chunks.pop(sorted(manifest.chunks)[-1])
    manifest.complete = False
    store.write_manifest(out, manifest)
    capsys.readouterr()
    assert main(["sweep", str(job), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "incomplete (42 of 48 designs committed); pass --resume to continue it" in err


@pytest.mark.slow
def test_verbose_prints_each_progress_line_once(tmp_path):
    job = write_job(tmp_path / "job.toml")
    command = [
        sys.executable,
        "-m",
        "dpfexplore",
        "-v",
        "sweep",
        str(job),
        "--out",
        str(tmp_path / "out"),
    ]
    stderr = subprocess.run(command, capture_output=True, text=True, timeout=300).stderr
    # progress lines and log records alike: the message after "sweep: ", once each
    said = [line.split(" sweep: ", 1)[1] for line in stderr.splitlines() if " sweep: " in line]
    assert len(said) >= 3 and len(said) == len(set(said)), stderr


def test_a_first_compilation_is_announced(tmp_path):
    from dpfexplore.model.design import load_design
    from dpfexplore.solvers.compilation import compile_notice
    from dpfexplore.solvers.statics import find_state

    # one design runs the serial kernels: `states` checks those, not the parallel batch ones
    find_state(load_design(example_path("gripper")), "11110")  # compiled (or loaded) here
    assert compile_notice(["states"]) is None
    # A fresh process with an empty cache has nothing compiled: it says so before compiling.
    code = (
        "from dpfexplore.solvers.compilation import compile_notice; "
        "print(compile_notice(['states', 'statics']))"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty-cache")}
    said = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    ).stdout
    assert said.startswith(
        "compiling the states and statics kernels for this machine (first run only"
    )


def test_solve_batch_alone_is_not_told_of_kernels_it_never_runs(monkeypatch):
    # the node positions of find_state's results are compiled only when asked for; a process
    # that only calls solve_batch on single designs must not announce a compilation while every
    # kernel it runs is cached
    from dpfexplore._kernels.statics import states as kstates
    from dpfexplore.solvers import compilation

    monkeypatch.setattr(compilation, "_SETTLED", set())
    monkeypatch.setattr(compilation, "is_cached", lambda kernel: kernel is not kstates.nodes_of)
    assert compilation.compile_notice(["states"]) is None


def test_the_python_api_announces_a_first_compilation_once(monkeypatch, caplog):
    # what a fresh cache reports, without paying for the compilation: the states group missing
    import logging

    from dpfexplore import find_state, load_design
    from dpfexplore.solvers import compilation

    monkeypatch.setattr(compilation, "_SETTLED", set())
    monkeypatch.setattr(compilation, "uncompiled", lambda groups: list(groups))
    design = load_design(example_path("gripper"))
    watchers = list(compilation._WATCHERS)
    with caplog.at_level(logging.WARNING, logger="dpfexplore.compile"):
        find_state(design, "11110")
        find_state(design, "11100")
    said = [r.getMessage() for r in caplog.records if r.name == "dpfexplore.compile"]
    assert len(said) == 1 and said[0].startswith("compiling the states kernels"), said
    # the log line is the API's only notice: no progress display of its own on stderr
    assert compilation._WATCHERS == watchers
