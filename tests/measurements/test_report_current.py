"""The validation report the docs show, and the README's line, are today's figures."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from dpfexplore.measurements import validate
from dpfexplore.measurements.report import markdown_report

ROOT = Path(__file__).parents[2]
REPORT = ROOT / "results" / "reports" / "validation.md"
COMMAND = (
    "dpfexplore validate --plot results/reports/validation.png "
    "--report results/reports/validation.md"
)


@pytest.fixture(scope="module")
def result():
    return validate()


def test_the_committed_report_is_what_the_command_writes_today(result):
    # made again by the command in the report (from the repository root) when a packaged set or
    # the measurements change
    assert COMMAND in REPORT.read_text()
    assert REPORT.read_text() == markdown_report(result, command=COMMAND, figure="validation.png")
    assert (REPORT.parent / "validation.png").stat().st_size > 50_000


def test_the_readme_states_the_paper_set_s_figures(result):
    line = next(
        line
        for line in (ROOT / "README.md").read_text().splitlines()
        if "dpfexplore validate" in line
    )
    ninja = result.summary("paper", "NinjaFlex 85A").mean_distance
    cheetah = result.summary("paper", "Cheetah 95A").mean_distance
    assert f"mean tip distance {ninja:.2f} mm NinjaFlex 85A, {cheetah:.2f} mm Cheetah 95A" in line
    worst = result.summary("paper", "Cheetah 95A").max_stiffness_error
    stated = int(re.search(r"stiffnesses within (\d+) %", line).group(1))
    assert worst <= stated / 100 < worst + 0.01
    assert "shell-extended" in line and not result.verdict("shell-extended").passes
