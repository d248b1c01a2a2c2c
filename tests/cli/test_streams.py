"""A lost reader, a closed stream or an early Ctrl-C never changes what a command does.

Real processes, real pipes and closed descriptors: ``2>&1 | head -1`` (the reader goes away
after one line), ``2>&-`` and ``>&-`` (the descriptor is closed at start-up), SIGINT while the
command is still importing. And start-up stays cheap: ``import dpfexplore`` and ``dpfexplore
--help`` load no Numba.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from sweep_helpers import job_dict, toml_text

from dpfexplore.sweep.storage import store

GRIPPER = Path(__file__).parents[2] / "dpfexplore" / "examples" / "gripper.toml"
CLI = [sys.executable, "-m", "dpfexplore"]


def shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``command`` in bash with pipefail off; ``$DPF`` is the CLI."""
    env = {**os.environ, "DPF": " ".join(CLI)}
    return subprocess.run(
        ["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module")
def job(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("streams")
    path = root / "job.toml"
    changes = {"job.samples_per_n": 12, "job.chunk_size": 4, "space.n_units": [2, 3]}
    path.write_text(toml_text(job_dict(**changes)))
    return path


def test_a_reader_that_goes_away_does_not_stop_a_sweep(job, tmp_path):
    # head exits after the first line; the sweep keeps writing into a broken pipe
    done = shell(
        f'$DPF sweep {job} --out out 2>&1 | head -1; echo "rc=${{PIPESTATUS[0]}}"', tmp_path
    )
    assert done.stdout.strip().splitlines()[-1] == "rc=0", done.stdout + done.stderr
    manifest = store.read_manifest(tmp_path / "out")
    assert manifest.complete
    assert len(store.read_results(tmp_path / "out")) > 0


def test_a_closed_stderr_or_stdout_changes_nothing(job, tmp_path):
    done = shell(f"$DPF sweep {job} --out a 2>&-", tmp_path)
    assert done.returncode == 0
    assert store.read_manifest(tmp_path / "a").complete
    done = shell(f"$DPF states {GRIPPER} --plot p.png >&- 2>&-", tmp_path)
    assert done.returncode == 0
    assert (tmp_path / "p.png").stat().st_size > 0


def test_query_into_head_is_quiet_and_succeeds(job, tmp_path):
    assert shell(f"$DPF sweep {job} --out d", tmp_path).returncode == 0
    done = shell('$DPF query d --json | head -c 20; echo; echo "rc=${PIPESTATUS[0]}"', tmp_path)
    assert done.stdout.strip().endswith("rc=0")
    assert "Error" not in done.stderr and "Traceback" not in done.stderr
    whole = shell("$DPF query d --json", tmp_path)
    assert len(json.loads(whole.stdout)) == len(store.read_results(tmp_path / "d"))


@pytest.mark.parametrize("delay", [0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 2.0])
def test_ctrl_c_during_start_up_is_one_line(delay, tmp_path):
    process = subprocess.Popen(
        [*CLI, "states", str(GRIPPER)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    if "Traceback" in err:
        # only Python's own start-up (site, the editable-install finder), before any line of
        # the package runs, may still print one
        assert not re.search(r'File "[^"]*/dpfexplore/[^"]*"', err), err
    elif process.returncode != 0:  # it may also have finished before the signal
        # 130, or killed by SIGINT once the line is out: what a shell shows as $? = 130 too
        assert process.returncode in (130, -signal.SIGINT), err
        said = [line for line in err.splitlines() if "compiling the" not in line]  # cold cache
        assert len(said) == 1 and said[0].endswith("interrupted"), err


#: Run ``python -m dpfexplore --version`` under a profile hook and print each Python function that
#: starts with a ``dpfexplore`` frame on the stack before the CLI's SIGINT handler is installed.
_BEFORE_THE_GUARD = """
import _signal, runpy, sys
calls = []
def profile(frame, event, arg):
    if event == "c_call" and arg is _signal.signal:
        sys.setprofile(None)
        print("\\n".join(calls))
        raise SystemExit(0)
    f = frame
    while event == "call" and f is not None and "/dpfexplore/" not in f.f_code.co_filename:
        f = f.f_back
    if event == "call" and f is not None:
        calls.append(frame.f_code.co_filename.rpartition("/")[2] + ":" + frame.f_code.co_name)
sys.argv = ["dpfexplore", "--version"]
sys.setprofile(profile)
runpy._run_module_as_main("dpfexplore")
"""


def test_nothing_runs_in_the_package_before_the_ctrl_c_guard():
    # Python's default handler raises KeyboardInterrupt at the next call or frame entry after the
    # signal, with a traceback through the package while a package frame is on the stack. The
    # test above samples start-up at a few moments; this one sees every call deterministically:
    # before the guard, only the two module bodies and run() (definitions, microseconds), never
    # an import that runs Python code (signal.py with enum: about a millisecond).
    done = subprocess.run(
        [sys.executable, "-c", _BEFORE_THE_GUARD], capture_output=True, text=True, check=True
    )
    assert done.stdout.splitlines() == [
        "__init__.py:<module>",
        "__main__.py:<module>",
        "__main__.py:run",
    ]


def test_start_up_loads_no_numba():
    code = (
        "import sys, dpfexplore\n"
        "assert 'numba' not in sys.modules\n"
        "from dpfexplore.cli import main\n"
        "try:\n"
        "    main(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "heavy = [m for m in ('numba', 'scipy', 'pandas', 'pyarrow') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
        "print(dpfexplore.find_state.__module__)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    heavy, module = done.stdout.strip().splitlines()[-2:]
    assert heavy == ""
    assert module == "dpfexplore.solvers.statics"  # the lazy export still resolves


def test_version(capsys):
    import dpfexplore
    from dpfexplore.cli import main

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"dpfexplore {dpfexplore.__version__}"
