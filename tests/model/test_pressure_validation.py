"""One validation of pressure profiles, with a physical range, at every entry point."""

from __future__ import annotations

import pytest
from sweep_helpers import job_dict

from dpfexplore.cli import main
from dpfexplore.model.pressure import MAX_PRESSURE, PressureProfile
from dpfexplore.sweep.job_file import JobSpecError, parse_job

PULSE = {"tau": [0.0, 1.0, 5.0, 5.1], "t_end": 9.0}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(P0=-0.7, tau=(0, 1, 5, 5.1)), r"^P0 = -0\.7: must be a finite pressure > 0 MPa"),
        (dict(P0=0.0, tau=(0, 1, 5, 5.1)), r"^P0 = 0\.0: must be a finite pressure > 0 MPa"),
        (dict(P0=100.0, tau=(0, 1, 5, 5.1)), r"^P0 = 100\.0: above 2 MPa"),
        (dict(P0=0.7, tau=(-2, -1, 0, 0.1)), r"^tau\[0\] = -2\.0: must be a finite time >= 0 s"),
        (dict(times=(0, 1, 2), pressures=(0, -5, 0)), r"^pressures\[1\] = -5\.0: must be a"),
        (dict(times=(0, 1), pressures=(0, 2.5)), r"^pressures\[1\] = 2\.5: above 2 MPa"),
    ],
)
def test_profiles_outside_the_physical_range_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PressureProfile(**kwargs)


def test_the_range_itself_is_accepted():
    assert MAX_PRESSURE == 2.0
    PressureProfile(P0=MAX_PRESSURE, tau=(0, 1, 5, 5.1))
    PressureProfile((0.0, 1.0, 2.0), (0.0, 0.0, 0.0))  # zero pressure: a relaxation run


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--P0", "-0.7"], "--P0: P0 = -0.7: must be a finite pressure > 0 MPa"),
        (["--P0", "100"], "--P0: P0 = 100.0: above 2 MPa"),
        (["--profile", "0:0,1:-5,2:0"], "--profile: pressures[1] = -5.0: must be a finite"),
        (["--tau", "-2,-1,0,0.1"], "--tau: tau[0] = -2.0: must be a finite time >= 0 s"),
    ],
)
def test_simulate_refuses_them_in_one_line(argv, expected, capsys):
    assert main(["simulate", "pickplace", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], lines
    assert "expected one argument" not in lines[0]


@pytest.mark.parametrize(
    ("P0", "key", "reason"),
    [
        (-0.7, "compute.reset_times.P0 = -0.7", "must be a finite pressure > 0 MPa"),
        (100.0, "compute.reset_times.P0 = 100.0", "above 2 MPa"),
    ],
)
def test_job_files_refuse_the_same_pressures_with_the_same_reason(P0, key, reason):
    with pytest.raises(JobSpecError) as info:
        parse_job(job_dict(**{"compute.reset_times": {"P0": P0, **PULSE}}))
    assert str(info.value).startswith(key) and reason in str(info.value)
    with pytest.raises(ValueError, match=reason):
        PressureProfile(P0=P0, tau=PULSE["tau"])


def test_job_tau_before_zero_is_refused_by_the_same_rule():
    with pytest.raises(JobSpecError, match=r"^compute\.reset_times\.tau\[0\] = -1\.0: must be"):
        parse_job(
            job_dict(
                **{"compute.reset_times": {"P0": 0.7, "tau": [-1.0, 1.0, 5.0, 5.1], "t_end": 9.0}}
            )
        )
