"""``--json``: stdout holds exactly one JSON document, whatever the command or its libraries print.

Each command runs in its own process so that anything written to the real stdout (by us, a
dependency, or C code) is caught. Strict parsing: NaN and Infinity are not JSON.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from sweep_helpers import job_dict, toml_text


def strict(text: str):
    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


COMMANDS = {
    "states": ["states", "gripper", "--json"],
    "snap": ["snap", "gripper", "--P-max", "0.7", "--json"],
    "simulate-leg": ["simulate-leg", "walker-leg", "--json"],
    "reset-model report": ["reset-model", "report", "--json"],
    "bench statics": [
        "bench",
        "statics",
        "--json",
        "--no-compile",
        "--units",
        "2",
        "--designs",
        "3",
        "--scipy-designs",
        "2",
        "--rounds",
        "1",
    ],
}


def run(argv, cwd):
    done = subprocess.run(
        [sys.executable, "-m", "dpfexplore", *argv],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_stdout_is_one_json_document(name, tmp_path):
    document = strict(run(COMMANDS[name], tmp_path))
    assert isinstance(document, dict | list) and document


def test_query_json(tmp_path):
    job = tmp_path / "job.toml"
    job.write_text(toml_text(job_dict(**{"job.samples_per_n": 6, "space.n_units": [2]})))
    run(["sweep", str(job), "--out", str(tmp_path / "d")], tmp_path)
    rows = strict(run(["query", str(tmp_path / "d"), "--json"], tmp_path))
    assert isinstance(rows, list) and len(rows) > 0
