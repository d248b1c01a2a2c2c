"""Every command that writes a result directory, killed (SIGKILL) at points through its run:
afterwards the directory holds the previous complete result or the new one, and the readers that
use it (``states`` on a written design, ``surrogate report``, ``verify_result_dir``) accept it.

The kill delays are spread over each command's measured run time (an uninterrupted run first),
so that some land during the work and some during the write; the run after the killed ones, left
to finish, cleans what they left.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest
from sweep_helpers import job_dict, toml_text
from test_result_commands import scene

from dpfexplore.cli import main
from dpfexplore.io.result_dirs import verify_result_dir


def run(argv, cwd):
    return subprocess.run(
        [sys.executable, "-m", "dpfexplore", *argv], cwd=cwd, capture_output=True, text=True
    )


def killed_after(argv, cwd, delay: float) -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "dpfexplore", *argv],
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        process.wait(timeout=delay)  # finished before the kill: nothing to wait for
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGKILL)
        process.wait()


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("killed")
    job = root / "job.toml"
    job.write_text(toml_text(job_dict(**{"job.samples_per_n": 40, "space.n_units": [3]})))
    assert main(["sweep", str(job), "--out", str(root / "d")]) == 0
    return root / "d"


def commands(tmp_path, dataset):
    """(name, argv writing ``out``, check of a complete result)."""

    # the readers run in this process: the same code as a command's, without a start-up each
    def designs_readable(out):
        files = sorted(out.glob("*.toml"))
        assert files
        assert main(["states", str(files[0])]) == 0

    def surrogate_readable(out):
        assert main(["surrogate", "report", str(out)]) == 0

    return [
        ("design", ["design", str(scene(tmp_path, 2)), "--force"], designs_readable),
        (
            "lookup --write",
            ["lookup", str(dataset), "--target", "40,30", "--k", "3", "--force", "--write"],
            designs_readable,
        ),
        (
            "surrogate fit",
            [
                "surrogate",
                "fit",
                str(dataset),
                "--outputs",
                "tip_x,tip_y",
                "--kinds",
                "knn",
                "--no-timing",
                "--force",
                "--out",
            ],
            surrogate_readable,
        ),
    ]


@pytest.mark.parametrize("which", [0, 1, 2])
def test_a_killed_command_leaves_the_previous_or_the_new_result(which, tmp_path, dataset):
    name, argv, readable = commands(tmp_path, dataset)[which]
    out = tmp_path / "out"
    full = [*argv, str(out)] if argv[-1] in ("--write", "--out") else [*argv, "--out", str(out)]
    for _ in range(2):  # timed warm: the session compiled the kernels, or this first run does
        started = time.perf_counter()
        done = run(full, tmp_path)
        took = time.perf_counter() - started
        assert done.returncode in (0, 1), done.stderr  # 1: a target not met is still a result
        if "compiling the" not in done.stderr:
            break
    verify_result_dir(out)
    for fraction in (0.35, 0.75):
        killed_after(full, tmp_path, fraction * took)
        verify_result_dir(out)  # complete: the previous result or the new one
        readable(out)
        leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".out.")]
        assert all("staging" in n or "lock" in n for n in leftovers), leftovers
    # the next run, not killed, cleans what the killed ones left and succeeds
    assert run(full, tmp_path).returncode in (0, 1)
    verify_result_dir(out)
    readable(out)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.staging")], name
