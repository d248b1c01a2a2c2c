"""Job specs: one-line errors naming the key, round trip, fingerprint, the shipped jobs."""

from __future__ import annotations

from pathlib import Path

import pytest
from sweep_helpers import DELETE, job_dict, make_job, toml_text

from dpfexplore.sweep.job_file import JobSpecError, load_job, parse_job

JOBS = Path(__file__).parents[2] / "jobs"


def test_valid_job_defaults_and_counts():
    spec = make_job()
    assert spec.space.n_units == (2, 3)
    assert spec.n_designs == 120
    assert spec.max_units == 3
    E = spec.space.variable("E")
    assert (E.low, E.high) == (26.0, 26.0) and not E.sampled  # from the material preset
    assert spec.space.variable("H").sampled
    assert spec.compute.reset_times is None


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"job.sead": 3}, "job.sead"),  # unknown key
        ({"space.variables.Hmax": 3.0}, "space.variables.Hmax"),
        ({"compute.stifness": True}, "compute.stifness"),
        ({"job.seed": DELETE}, "job.seed"),  # missing key
        ({"space.variables.t_lim": DELETE}, "space.variables.t_lim"),
        ({"compute": DELETE}, "compute"),
        ({"space.variables.H": {"min": 5.0, "max": 3.0}}, "space.variables.H.min"),  # min > max
        ({"space.variables.U_L": {"min": "5.5", "max": 10.0}}, "space.variables.U_L.min"),
        ({"space.variables.t": "thin"}, "space.variables.t"),  # non-numeric
        ({"job.samples_per_n": 1.5}, "job.samples_per_n"),
        ({"job.seed": -1}, "job.seed"),
        ({"space.n_units": [2, 13]}, "space.n_units"),  # N out of range
        ({"space.n_units": {"min": 0, "max": 3}}, "space.n_units.min"),
        ({"space.n_units": [2, "3"]}, "space.n_units[1]"),
        ({"space.variables.H": {"min": -1.0, "max": 3.0}}, "space.variables.H.min"),
        ({"space.variables.t": float("nan")}, "space.variables.t"),
        ({"space.variables.nu": 0.5}, "space.variables.nu"),
        ({"space.variables.E": 12.0}, "space.variables.E"),  # both material and E
        ({"space.material": "unobtainium"}, "space.material"),
        ({"space.constraints.heights": "sorted"}, "space.constraints.heights"),
        ({"space.constraints.equal_U_L": "yes"}, "space.constraints.equal_U_L"),
        ({"compute.states": "everything"}, "compute.states"),
        (
            {"compute.reset_times": {"P0": 0.7, "tau": [0, 1, 5], "t_end": 9.0}},
            "compute.reset_times.tau",
        ),
        (
            {"compute.reset_times": {"P0": 0.7, "tau": [0, 1, 5, 5.1], "t_end": 5.0}},
            "compute.reset_times.t_end",
        ),
        (
            {"compute.reset_times": {"P0": 0.0, "tau": [0, 1, 5, 5.1], "t_end": 9.0}},
            "compute.reset_times.P0",
        ),
        ({"compute.reset_times": True}, "compute.reset_times"),
        (
            {
                "compute.reset_times": {
                    "P0": 0.7,
                    "tau": [0, 1, 5, 5.1],
                    "t_end": 9.0,
                    "method": "euler",
                }
            },
            "compute.reset_times.method",
        ),
        ({"job.name": "a/b"}, "job.name"),
    ],
)
def test_bad_job_names_the_key_in_one_line(changes, key):
    with pytest.raises(JobSpecError) as info:
        parse_job(job_dict(**changes))
    message = str(info.value)
    assert message.startswith(key + " ") or message.startswith(key + ":"), message
    assert "\n" not in message


def test_to_dict_round_trips():
    spec = make_job(
        **{
            "space.constraints.heights": "descending",
            "space.constraints.equal_U_L": True,
            "space.variables.E": 12.0,
            "space.material": DELETE,
            "compute.reset_times": {"P0": 0.7, "tau": [0.0, 1.0, 5.0, 5.1], "t_end": 15.0},
            "job.chunk_size": 10,
        }
    )
    assert parse_job(spec.to_dict()) == spec


def test_fingerprint_covers_results_only():
    base = make_job()
    assert (
        make_job(**{"job.name": "renamed", "job.chunk_size": 5}).fingerprint() == base.fingerprint()
    )
    for changes in (
        {"job.seed": 8},
        {"job.samples_per_n": 61},
        {"job.sampler": "sobol"},
        {"space.variables.t": {"min": 0.5, "max": 0.9}},
        {"space.constraints.heights": "ascending"},
        {"compute.stiffness": False},
        {"compute.states": "sequential"},
    ):
        other = make_job(**changes)
        assert other.fingerprint() != base.fingerprint(), changes
        key = base.first_difference(other.result_defining())
        changed = next(iter(changes))
        assert key is not None and key.startswith(changed), (key, changes)


def test_load_job_reports_file_and_key(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(toml_text(job_dict(**{"space.variables.H": {"min": 5.0, "max": 3.0}})))
    with pytest.raises(JobSpecError, match=r"bad.toml: space.variables.H.min = 5.0: greater"):
        load_job(path)
    path.write_text("[job\nseed = 1")
    with pytest.raises(JobSpecError, match="not valid TOML"):
        load_job(path)
    with pytest.raises(JobSpecError, match="no such job file"):
        load_job(tmp_path / "missing.toml")


def test_default_name_is_file_stem(tmp_path):
    path = tmp_path / "my-sweep.toml"
    path.write_text(toml_text(job_dict(**{"job.name": DELETE})))
    assert load_job(path).name == "my-sweep"


def test_shipped_jobs():
    paper = load_job(JOBS / "paper-design-space.toml")
    assert paper.space.n_units == (2, 3, 4, 5, 6, 7)
    assert paper.samples_per_n == 1500
    expected = {
        "H": (3.0, 5.0),
        "U_sep": (1.0, 5.0),
        "U_L": (5.5, 10.0),
        "t": (0.5, 1.0),
        "t_lim": (1.0, 2.0),
    }
    for name, bounds in expected.items():
        variable = paper.space.variable(name)
        assert (variable.low, variable.high) == bounds
    assert paper.compute.states == "all_inverted" and paper.compute.stiffness
    assert paper.compute.reset_times is None

    overnight = load_job(JOBS / "overnight.toml")
    assert overnight.n_designs >= 10**6
    assert overnight.space.n_units == (2, 3, 4, 5, 6, 7, 8)
    assert overnight.compute.states == "sequential"
    assert overnight.compute.stiffness and overnight.compute.reset_times is not None

    smoke = load_job(JOBS / "smoke.toml")
    assert smoke.n_designs <= 500


def test_sobol_plan_size_warns_unless_power_of_two(caplog):
    make_job(**{"job.sampler": "sobol", "job.samples_per_n": 64})
    assert not caplog.records
    make_job(**{"job.sampler": "sobol", "job.samples_per_n": 60})
    assert "not a power of 2" in caplog.text


def test_reset_time_method_accepted():
    spec = make_job(
        **{
            "compute.reset_times": {
                "P0": 0.7,
                "tau": [0, 1, 5, 5.1],
                "t_end": 9.0,
                "method": "rodas4-overdamped",
            }
        }
    )
    assert spec.compute.reset_times.method == "rodas4-overdamped"
