"""Timing scenes (issue 14): pick-and-place reset times and walker-leg zones, end to end.

Every reported design is re-simulated here, alone, by the full model at a tight tolerance, and
must do what its report says. Scenes are shrunk (coarse grids, few lines of t) to keep this quick.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dpfexplore import Design, DesignBatch, PressureProfile, simulate
from dpfexplore.cli import main
from dpfexplore.inverse.engine.roots import grow_bracket, root_on_line
from dpfexplore.inverse.kinds import load_scene
from dpfexplore.inverse.scene_file import SceneSpecError
from dpfexplore.inverse.scenes.pickplace.problem import ResetEval, line_brackets
from dpfexplore.inverse.scenes.pickplace.spec import with_target_reset
from dpfexplore.inverse.scenes.walker.report import inverted_intervals
from dpfexplore.inverse.scenes.walker.solve import violation
from dpfexplore.solvers.dynamics.ramp import inversion_pressures
from dpfexplore.solvers.legs.leg import load_leg, simulate_leg

JOBS = Path(__file__).parents[2] / "jobs"
PULSE = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
TIGHT = 1e-7


def pickplace(h: float, t: float) -> Design:
    return Design(H=[4.0, 4.5, 5.0, 5.0, h, h], U_L=6.0, U_sep=1.0, t=t, t_lim=1.0, E=26.0)


def pickplace_scene(targets, *, extra: str = "", grid: str = "{t = 6, H = 21}") -> str:
    return f"""
[scene]
kind = "pickplace"
name = "pp-test"
material = "cheetah-95a"
[variables]
n_units = 6
H = [4.0, 4.5, 5.0, 5.0, {{min = 2.9, max = 3.4}}, {{min = 2.9, max = 3.4}}]
tied = [[5, 6]]
U_L = 6.0
U_sep = 1.0
t = {{min = 0.8, max = 1.0}}
t_lim = 1.0
[pickplace]
targets = {json.dumps(list(targets))}
grid = {grid}
{extra}
"""


def full_run(design: Design):
    """The full model, alone, to the horizon, tight."""
    return simulate(design, PULSE, t_end=15.0, atol=TIGHT, n_samples=0)


# --- root finding pieces (synthetic, exact answers) ------------------------------------------


def test_root_on_line_closes_a_diverging_bracket():
    # A reset time that diverges at an edge x = 0.7, like a metastable unit's near bistability;
    # beyond the edge it never resets (log ratio +50), as the screening reports.
    def log_ratio(x: float) -> float:
        return 50.0 if x >= 0.7 else math.log((0.1 / (0.7 - x)) / 2.0)

    x, calls = root_on_line(log_ratio, 0.0, 1.0, log_ratio(0.0), 50.0, ftol=1e-12, xtol=1e-14)
    assert x == pytest.approx(0.65, abs=1e-10)  # 0.1 / (0.7 - 0.65) = 2
    assert calls < 60
    grown = grow_bracket(log_ratio, 0.6, step=0.01)
    assert grown is not None and grown[0] <= 0.65 <= grown[1]


def test_line_brackets_find_sign_changes_along_lines_only():
    z = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 1.0], [1.0, 1.0]])
    value = np.array([0.5, 1.5, np.inf, 0.2, 0.4, np.nan])
    admissible = np.isfinite(value) | np.isinf(value)
    ev = ResetEval(
        z=z,
        reset=np.zeros((6, 1)),
        classes=np.zeros((6, 1), int),
        final_state=np.zeros(6, int),
        status=np.zeros(6, np.int8),
        value=value,
        admissible=admissible,
        method="test",
    )
    brackets = line_brackets(ev, (2, 3), 1.0, fitted=np.ones(6, bool), stiffness=np.ones(6))
    assert [(b.z_lo, b.z_hi) for b in brackets] == [((0.0, 0.0), (0.5, 0.0))]
    assert brackets[0].f_lo == pytest.approx(math.log(0.5))


def test_inverted_intervals_and_violation():
    class Run:
        design = Design(H=[3.0, 3.0], U_L=6.5, U_sep=1.0, t=0.8, t_lim=1.0)
        events = np.array(
            [
                [0.1, 1, 1],
                [0.2, 2, 1],
                [1.5, 1, -1],
                [1.6, 2, -1],
                [1.62, 2, 1],
                [2.0, 2, -1],
                [3.0, 1, 1],
            ]
        )

    assert inverted_intervals(Run(), 4.0) == [[(0.1, 1.5), (3.0, 4.0)], [(0.2, 1.6), (1.62, 2.0)]]
    reqs = [
        {"met": True, "value": 1.0, "bound": 2.0},
        {"met": False, "value": 0.5, "bound": 1.0},
        {"met": False, "value": "monostable", "bound": "metastable"},
    ]
    assert violation(reqs) == pytest.approx(1.5) and violation(reqs[:1]) == 0.0


# --- pick-and-place ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def known_target():
    """The last tip unit's reset time of a known design (full model, tight)."""
    design = pickplace(3.12, 0.9)
    run = full_run(design)
    assert run.unit_class[:4] == ("bistable",) * 4 and run.unit_class[4] == "metastable"
    return float(np.max(run.reset_time[4:][np.isfinite(run.reset_time[4:])]))


def test_known_reset_time_is_recovered_and_verified(known_target, tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(pickplace_scene([1.0]))
    out = tmp_path / "out"
    code = main(
        ["design", str(path), "--out", str(out), "--json", "--target-reset", repr(known_target)]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    (row,) = record["results"]
    for key in ("design", "reset_times", "target_reset", "stiffness", "evaluations", "wall_s"):
        assert key in row
    assert row["target_reset"] == known_target and row["reachable"]
    assert row["evaluations"]["simulations"] > 0 and row["evaluations"]["verifications"] > 0
    assert record["evaluations"]["screening"] > 0
    # Re-simulated here: the design does what the report says.
    design = Design.from_dict(row["design"])
    run = full_run(design)
    assert run.unit_class[:4] == ("bistable",) * 4 and run.final_state == "111100"
    last = float(np.max(run.reset_time[4:][np.isfinite(run.reset_time[4:])]))
    assert abs(last / known_target - 1.0) <= 0.01
    assert row["reset_time"] == pytest.approx(last, rel=1e-5)
    assert list(run.unit_class) == row["classes"]
    assert row["fitted_range"] is design.in_fitted_range
    rng = row["reachable_range"]["all"]
    assert rng["min_s"] <= known_target <= row["reachable_range"]["supremum_s"]
    # The result TOML reads back as a design.
    saved = tomllib.loads((out / "result-01.toml").read_text())
    assert Design.from_dict(saved["design"]) == design


def test_paper_finger_reset_times_as_targets(tmp_path, capsys):
    """Both tip units' reset times of the paper's finger (H = 3.0, t = 0.83) at once."""
    paper = full_run(pickplace(3.0, 0.83)).reset_time[4:]
    extra = f"[[pickplace.unit_targets]]\nunits = [5, 6]\nreset = {list(map(float, paper))}"
    path = tmp_path / "scene.toml"
    path.write_text(pickplace_scene([], extra=extra, grid="{t = 5, H = 21}"))
    assert main(["design", str(path), "--out", str(tmp_path / "o"), "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["results"]
    assert row["target_units"] == [5, 6] and row["reachable"]
    run = full_run(Design.from_dict(row["design"]))
    assert run.unit_class[:4] == ("bistable",) * 4
    np.testing.assert_allclose(run.reset_time[4:], paper, rtol=0.01)


def test_two_profile_difference_front_is_verified(tmp_path, capsys):
    extra = (
        "[pickplace.difference]\nprofile = {P0 = 1.0, tau = [0.0, 1.0, 5.0, 5.1]}\n"
        "max_reset = 6.0\nweights = [1.0, 1.0]"
    )
    path = tmp_path / "scene.toml"
    path.write_text(pickplace_scene([], extra=extra, grid="{t = 4, H = 21}"))
    assert main(["design", str(path), "--out", str(tmp_path / "o"), "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["results"]
    assert row["objective_kind"] == "difference" and row["front"]
    second = PressureProfile.pulse(1.0, (0.0, 1.0, 5.0, 5.1))
    for point in row["front"]:
        design = Design.from_dict(point["design"])
        r1 = full_run(design)
        r2 = simulate(design, second, t_end=15.0, atol=TIGHT, n_samples=0)
        last1, last2 = (
            float(np.nanmax(np.where(np.isinf(r.reset_time[4:]), np.nan, r.reset_time[4:])))
            for r in (r1, r2)
        )
        assert last1 <= 6.0 and last2 <= 6.0
        assert r1.unit_class[:4] == ("bistable",) * 4 == r2.unit_class[:4]
        assert point["difference"] == pytest.approx(last2 - last1, abs=1e-5)
    pairs = [(q["difference"], q["stiffness"]) for q in row["front"]]
    for d, k in pairs:  # non-dominated
        assert not any(d2 >= d and k2 >= k and (d2, k2) != (d, k) for d2, k2 in pairs)
    assert row["weighted"]["weights"] == [1.0, 1.0]


def test_target_reset_option_and_bad_pickplace_input(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(pickplace_scene([1.0]))
    spec = with_target_reset(load_scene(path), 2.5)
    assert spec.pickplace.targets == (2.5,) and spec.pickplace.difference is None
    bad = [
        (["--target-reset", "12"], "--target-reset 12.0: must be in (0, 9.9) s"),
        (["--target-reset", "-1"], "--target-reset -1.0"),
    ]
    for args, message in bad:
        out = tmp_path / "never"
        assert main(["design", str(path), "--out", str(out), *args]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1 and not out.exists()
    position = JOBS / "design-position-cheetah.toml"
    assert main(["design", str(position), "--target-reset", "1"]) == 2
    assert "only for pick-and-place scenes" in capsys.readouterr().err


@pytest.mark.parametrize(
    "change, key",
    [
        (("targets = [1.0]", "targets = [20.0]"), "pickplace.targets"),
        (("tied = [[5, 6]]", "tied = []"), "variables: free"),
        (("[pickplace]", "[pickplace]\nreset_unit = 2"), "pickplace.reset_unit"),
        (("[pickplace]", "[pickplace]\nscreening = 'magic'"), "pickplace.screening"),
        (("[pickplace]", "[pickplace]\nhold_units = [1, 9]"), "pickplace.hold_units"),
        (("[pickplace]", "[pickplace]\nfoo = 1"), "pickplace.foo = 1: unknown key"),
    ],
)
def test_bad_pickplace_scene_one_line_exit_2(tmp_path, capsys, change, key):
    path = tmp_path / "scene.toml"
    path.write_text(pickplace_scene([1.0]).replace(*change))
    out = tmp_path / "out"
    assert main(["design", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert key in err and err.count("\n") == 1 and not out.exists()


# --- walker leg --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def walker(tmp_path_factory):
    """The shipped walker scene with two lines of t per section, through the CLI."""
    root = tmp_path_factory.mktemp("walker")
    text = (JOBS / "design-walker-leg.toml").read_text().replace("t_lines = 4", "t_lines = 2")
    path = root / "scene.toml"
    path.write_text(text)
    out = root / "out"
    code = main(["design", str(path), "--out", str(out), "--json"])
    return {"code": code, "out": out, "spec": load_scene(path)}


def _row(walker, kind):
    summary = json.loads((walker["out"] / "summary.json").read_text())
    return next(r for r in summary["results"] if r["leg"] == kind)


def _unit(row, section, unit):
    return next(u for u in row["units"] if u["section"] == section and u["unit"] == unit)


def test_walker_front_leg_meets_its_requirements_when_resimulated(walker):
    assert walker["code"] == 0
    row, spec = _row(walker, "front"), walker["spec"]
    g, req = spec.walker.gait, spec.walker.requirements
    assert row["reachable"] and row["requirements_met"] and row["objective"] == 0
    assert row["fitted_range"] is False and "purple" in row["fitted_range_note"]
    purple = Design.from_dict(row["design"]["purple"])
    run = simulate(purple, g.phase(1), t_end=g.phase1[3] + 5.0, atol=TIGHT, n_samples=0)
    assert run.unit_class == ("metastable", "metastable")
    lo, hi = req.purple_reset
    assert np.all((run.reset_time >= lo) & (run.reset_time <= hi))
    assert _unit(row, "purple", 1)["reset_time"] == pytest.approx(run.reset_time[0], rel=1e-6)
    action = Design.from_dict(row["design"]["action"])
    turn = simulate(
        action,
        g.phase(2, pressure=g.turn_pressure),
        t_end=g.phase2[3] + 8.0,
        atol=TIGHT,
        n_samples=0,
    )
    assert turn.unit_class == ("metastable", None, None, None)
    assert turn.reset_time[0] >= req.front_action_min_reset
    walk = simulate(action, g.phase(2), t_end=g.phase2[3] + 2.0, atol=TIGHT, n_samples=0)
    assert walk.unit_class == (None, None, None, None)  # flat while walking
    # Inversion pressures: the purple zone below the walking pressure, the action unit between
    # the walking and turning pressures (slow ramps, independent of the scene's search).
    p = inversion_pressures(DesignBatch.from_designs([purple, action]))
    m = req.margin
    assert np.all(p[0, :2] <= g.walk_pressure - m)
    assert g.walk_pressure + m <= p[1, 0] <= g.turn_pressure - m
    assert p[1, 1] >= g.turn_pressure + m
    # the scene's pressures (continuation) agree with the ramps to their ~1 % accuracy
    assert _unit(row, "action", 1)["inversion_pressure_MPa"] == pytest.approx(p[1, 0], rel=0.02)
    assert _unit(row, "purple", 2)["inversion_pressure_MPa"] == pytest.approx(p[0, 1], rel=0.02)


def test_walker_legs_written_reproduce_stride_through_simulate_leg(walker):
    spec = walker["spec"]
    mono = load_leg(walker["out"] / "leg-front.toml")  # only for its gait
    base = spec.walker.monostable_leg
    monostable = replace(base, phases=mono.phases, t_end=mono.t_end)
    ref = simulate_leg(monostable)
    assert ref.sections[0].result.unit_class == ("no_contact", "no_contact")
    for kind in ("front", "middle"):
        row = _row(walker, kind)
        leg = simulate_leg(load_leg(walker["out"] / f"leg-{kind}.toml"))
        assert leg.stride == pytest.approx(row["stride"], rel=1e-6)
        assert ref.stride == pytest.approx(row["monostable_stride"], rel=1e-6)
        assert leg.stride >= spec.walker.requirements.min_stride_ratio * ref.stride
    middle = _row(walker, "middle")
    assert _unit(middle, "action", 1)["class"] == "monostable"
    # the monostable leg's purple domes have no contact (H = 1.1, t = 1: d clamped), classed so
    assert middle["monostable_sections"][0]["classes"] == ["no_contact", "no_contact"]
    assert middle["monostable_sections"][0]["reset_times"] == [None, None]


def test_bad_walker_scene_one_line_exit_2(tmp_path, capsys):
    text = (JOBS / "design-walker-leg.toml").read_text()
    cases = [
        (("turn_pressure = 0.35", "turn_pressure = 0.1"), "walker.gait.turn_pressure"),
        (('leg = "walker-leg"', 'leg = "no-such-leg.toml"'), "walker.leg"),
        (("purple_aim = [1.25, 1.55]", "purple_aim = [0.5, 1.55]"), "walker.requirements"),
        (("period = 3.0", "period = 1.0"), "walker.gait.period"),
        (("[walker.search]", "[walker.search]\nfoo = 2"), "walker.search.foo = 2: unknown key"),
    ]
    for change, key in cases:
        path = tmp_path / "scene.toml"
        path.write_text(text.replace(*change))
        out = tmp_path / "out"
        assert main(["design", str(path), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert key in err and err.count("\n") == 1 and not out.exists()
    leg = tmp_path / "leg.toml"
    leg.write_text("[leg]\nt_end = 2.0\n[[section]]\nphase = '1'\ndesign = {H = [3.0]}\n")
    path = tmp_path / "scene.toml"
    path.write_text(text.replace('leg = "walker-leg" ', f'leg = "{leg}" '))
    assert main(["design", str(path)]) == 2
    assert "walker.leg" in capsys.readouterr().err


def test_shipped_timing_scenes_validate():
    pp = load_scene(JOBS / "design-pickplace.toml")
    assert pp.pickplace.targets == (0.3, 1.0, 2.0, 3.0) and pp.pickplace.n_results == 6
    w = load_scene(JOBS / "design-walker-leg.toml")
    assert w.walker.legs == ("front", "middle") and w.walker.gait.walk_pressure == 0.2
    with pytest.raises(SceneSpecError, match="walker: missing"):
        from dpfexplore.inverse.kinds import parse_scene

        parse_scene({"scene": {"kind": "walker_leg", "material": "cheetah-95a"}})


@pytest.mark.slow
def test_bench_design_timing_rows(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(
        [
            "bench",
            "design",
            "--json",
            "--skip-position",
            "--skip-gripper",
            "--pickplace-targets",
            "1",
            "--timing-tpe-factor",
            "1",
            "--timing-min-seconds",
            "0.5",
        ]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    rows = {r["scene"]: r for r in record["rows"]}
    assert set(rows) == {"pickplace", "walker-front", "walker-middle"}
    pp = rows["pickplace"]
    assert pp["ours_objective"] <= 0.01 and pp["ours_wall_s"] is not None
    assert pp["methods"]["tpe"]["evals"] > 0 and pp["target"] == [1.0]
    for kind in ("walker-front", "walker-middle"):
        assert rows[kind]["ours_objective"] == 0.0  # every requirement met
        assert rows[kind]["methods"]["tpe"]["evals"] > 0
    assert len(record["summary"]["timing_scenes"]) == 3


def test_walker_table_names_units_that_never_invert(capsys):
    from dpfexplore.inverse.scenes.walker.summary import leg_lines

    unit = {
        "section": "purple",
        "unit": 1,
        "H": 2.0,
        "t": 0.8,
        "class": None,
        "reset_time": "inf",
        "inversion_pressure_MPa": "inf",
        "phase": "phase 1",
        "pressure_MPa": 0.35,
    }
    row = {
        "leg": "front",
        "design": {},
        "stride": 1.0,
        "stride_ratio": 2.0,
        "monostable_stride": 0.5,
        "requirements": [],
        "wall_s": 1.0,
        "units": [unit, {**unit, "class": "metastable", "inversion_pressure_MPa": 0.21}],
    }
    print(*leg_lines([row]), sep="\n")  # the lines dpfexplore design prints
    out = capsys.readouterr().out
    assert "inf MPa" not in out and "flat" not in out
    assert "never inverts on the ramp" in out and "not inverted" in out
    assert "inverts at 0.2100 MPa" in out


def test_walker_turning_line_names_the_run_it_speaks_of(capsys):
    from dpfexplore.inverse.scenes.walker.summary import leg_lines

    row = {
        "leg": "front",
        "design": {},
        "stride": 1.0,
        "stride_ratio": 2.0,
        "monostable_stride": 0.5,
        "requirements": [],
        "wall_s": 1.0,
        "units": [],
        "turning": {
            "action_inverted_at_end": True,
            "action_inverts": True,
            "t_end": 5.0,
            "timing_figure_t_end": 8.0,
            "stride": 0.3,
        },
    }
    print(*leg_lines([row]), sep="\n")  # the lines dpfexplore design prints
    out = capsys.readouterr().out
    assert "end of the stride run (5 s; the timing figure runs 8 s)" in out
