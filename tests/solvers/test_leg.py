"""Legs (MODEL.md §10): composition against hand-computed transforms, sections against
single-finger simulations, the shipped example and the ``simulate-leg`` command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import spy
from plotting.figure_checks import assert_readable

import dpfexplore.cli as cli
from dpfexplore import Design, PressureProfile, simulate
from dpfexplore.examples import example_path
from dpfexplore.solvers.legs.kinematics import compose_chain, compose_dpw
from dpfexplore.solvers.legs.leg import (
    Leg,
    Section,
    apply_assignments,
    load_leg,
    section_nodes,
    simulate_leg,
)

# The walker's sections: p = U_L + t_ch + U_sep = 6.5 + 1 + 1, h = UC/2 + t_lim + t = 7.5 + 1 + 1.
P, H = 8.5, 9.5


def flat(n_units: int, p: float = P, h: float = H, m: int = 1) -> np.ndarray:
    """Rest nodes (m, 2N + 2, 2) written out: D_k = (k p, 0), L_k = (k p, h)."""
    nodes = np.zeros((m, 2 * n_units + 2, 2))
    for k in range(n_units + 1):
        nodes[:, 2 * k] = (k * p, 0.0)
        nodes[:, 2 * k + 1] = (k * p, h)
    return nodes


def rotate(vec, angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * vec[0] - s * vec[1], s * vec[0] + c * vec[1]])


# --- composition --------------------------------------------------------------------------------


def test_dpw_flat_sections_by_hand():
    placed = compose_dpw([flat(2), flat(1), flat(4)])
    r = math.hypot(P, H)
    cos1, sin1 = P / r, -H / r  # θ₁ = -atan2(h, p): v = D_2 - L_1 = (p, h) after the mirror
    # θ₂ = 0: section 2's L_1 - D_0 = (p, h) turned by θ₁ lies on +x, at distance r
    anchor = np.array([2 * P + r, 0.0])
    tip = placed[2][0, -1]
    # (4p, h, 0) -> R_x(90°) -> (4p, 0, h) -> R_z(θ₁) -> z negated -> + (anchor, 0)
    np.testing.assert_allclose(tip, [anchor[0] + 4 * P * cos1, 4 * P * sin1, -H], atol=1e-12)
    np.testing.assert_array_equal(placed[0][0, :, :2], flat(2)[0] * [1, -1])
    np.testing.assert_array_equal(placed[0][..., 2], 0.0)
    np.testing.assert_allclose(placed[1][0, 0, :2], [2 * P, 0.0], atol=1e-12)  # D_0 on D_2


def test_dpw_bent_section_by_hand():
    """Section 1's last unit turned by β about L_1 (two instants, two angles)."""
    betas = (0.3, -0.2)
    s1 = flat(2, m=2)
    for j, beta in enumerate(betas):
        for node in (4, 5):  # D_2 and L_2
            s1[j, node] = s1[j, 3] + rotate(s1[j, node] - s1[j, 3], beta)
    placed = compose_dpw([s1, flat(1, m=2), flat(4, m=2)])
    r = math.hypot(P, H)
    for j, beta in enumerate(betas):
        theta1 = beta - math.atan2(H, P)  # v = (p, -h) turned by β, mirrored: (p, h) by -β
        anchor = np.array([P, H]) + rotate([P, -H], beta)  # D_2, unmirrored
        top = anchor + r * np.array([math.cos(beta), math.sin(beta)])  # Q[L_1]; θ₂ = β
        heading = theta1 + beta
        expected = [top[0] + 4 * P * math.cos(heading), top[1] + 4 * P * math.sin(heading), -H]
        np.testing.assert_allclose(placed[2][j, -1], expected, atol=1e-12)


def test_chain_flat_and_mounted_by_hand():
    tip = compose_chain([flat(2), flat(3)], [0.0, 0.0])[1][0, -1]
    np.testing.assert_allclose(tip, [5 * P, H, 0.0], atol=1e-12)
    tip = compose_chain([flat(2), flat(3)], [0.0, 90.0])[1][0, -1]
    np.testing.assert_allclose(tip, [5 * P, 0.0, H], atol=1e-12)
    placed = compose_chain([flat(1), flat(1), flat(1)], [0.0, 90.0, -90.0])
    np.testing.assert_allclose(placed[2][0, -1], [3 * P, H, 0.0], atol=1e-12)


def test_chain_bent_by_hand():
    """Section 1's last post turned by β: section 2 follows the post's frame."""
    beta = 0.4
    s1 = flat(2)
    s1[0, 5] = s1[0, 4] + rotate([0.0, H], beta)
    e_x = np.array([math.cos(beta), math.sin(beta)])
    e_y = np.array([-math.sin(beta), math.cos(beta)])
    tip = compose_chain([s1, flat(3)], [0.0, 0.0])[1][0, -1]
    expected = np.array([2 * P, 0.0]) + 3 * P * e_x + H * e_y
    np.testing.assert_allclose(tip, [*expected, 0.0], atol=1e-12)


# --- sections are single-finger simulations ------------------------------------------------------


@pytest.fixture(scope="module")
def example_run():
    leg = load_leg(example_path("walker-leg-2.5"))
    return leg, simulate_leg(leg)


def test_sections_equal_single_finger_simulations(example_run):
    leg, result = example_run
    for run in result.sections:
        profile = leg.phases[run.section.phase]
        start = max(profile.zero_until(), 0.0)
        alone = simulate(
            run.section.design, profile, t_end=leg.t_end, t_start=start, n_samples=leg.n_samples
        )
        np.testing.assert_array_equal(run.result.x, alone.x)
        np.testing.assert_array_equal(run.result.reset_time, alone.reset_time)
        assert run.result.unit_class == alone.unit_class
        # starting at the phase instead of at 0 is exact up to the integration tolerance
        from_zero = simulate(run.section.design, profile, t_end=leg.t_end, n_samples=leg.n_samples)
        np.testing.assert_allclose(run.nodes, section_nodes(from_zero), atol=1e-3)
        np.testing.assert_allclose(run.result.reset_time, from_zero.reset_time, rtol=1e-4)
        assert run.result.unit_class == from_zero.unit_class
    assert [run.t_start for run in result.sections] == [0.0, 1.1, 1.1]


def test_example_leg_tip_path(example_run):
    leg, result = example_run
    out = result.to_dict()
    path = np.array(out["tip_path"])
    assert path.shape == (leg.n_samples, 4)
    np.testing.assert_array_equal(path[0], 0.0)
    np.testing.assert_allclose(path[:, 0], np.linspace(0, 5, 501), atol=1e-9)
    # the flat leg's tip, by hand (test_dpw_flat_sections_by_hand)
    r = math.hypot(P, H)
    np.testing.assert_allclose(
        out["tip_start"], [2 * P + r + 4 * P * P / r, -4 * P * H / r, -H], atol=1e-6
    )
    # phase 1 moves the tip in the z = 0 plane (sections 1-2), phase 2 out of it
    before = result.t < 1.1
    np.testing.assert_array_equal(result.tip_path[before, 2], 0.0)
    assert np.max(np.abs(result.tip_path[before, :2])) > 5.0
    assert np.max(np.abs(result.tip_path[~before, 2])) > 3.0
    assert [len(s["classes"]) for s in out["sections"]] == [2, 1, 4]
    assert out["fitted_range"] is False and "H[unit 1] = 2.5 mm" in out["fitted_range_note"]
    assert out["stride"] >= max(out["extent"]) > 0


def test_no_pressure_section_is_not_integrated():
    design = Design(H=[3.0, 3.0], U_L=6.5, U_sep=1.0, t=1.0, t_lim=1.0)
    leg = Leg(
        sections=[Section("a", design, "on"), Section("b", design, "off")],
        phases={
            "on": PressureProfile(P0=0.4, tau=(0.2, 0.3, 0.5, 0.6)),
            "off": PressureProfile.parse("0:0, 1:0"),
        },
        t_end=1.0,
        n_samples=11,
        composition="chain",
    )
    result = simulate_leg(leg)
    a, b = result.sections
    assert a.integrated and a.t_start == 0.2 and not b.integrated and b.t_start == 1.0
    np.testing.assert_allclose(b.nodes, flat(2, m=11), atol=1e-12)
    assert b.result.unit_class == (None, None) and result.to_dict()["evaluations"] == {
        "sections_integrated": 1,
        "sections_at_rest": 1,
        "steps": a.result.stats["steps"],
    }
    # before its phase, section a is exactly at rest too
    np.testing.assert_allclose(a.nodes[result.t < 0.2], flat(2, m=2), atol=1e-12)


def test_simulate_t_start_needs_a_quiet_profile():
    design = Design(H=[3.0], U_L=6.5, U_sep=1.0, t=1.0, t_lim=1.0)
    with pytest.raises(ValueError, match=r"t_start = 0\.5 s: the pressure is not 0"):
        simulate(design, PressureProfile(P0=0.4, tau=(0.2, 0.3, 0.5, 0.6)), t_end=1.0, t_start=0.5)
    assert PressureProfile(P0=0.4, tau=(1.1, 1.2, 2.2, 2.3)).zero_until() == 1.1
    assert PressureProfile.parse("0:0, 1:0, 1:0.3, 2:0").zero_until() == 1.0
    assert PressureProfile.parse("0:0, 1:0").zero_until() == math.inf
    assert PressureProfile.parse("0:0.1, 1:0").zero_until() == -math.inf


def test_assignments():
    changes = ["purple.H=2.5", "action.H=3.0,4.5,4.5,4.5", "green.t=0.9"]
    leg = apply_assignments(load_leg(example_path("walker-leg")), changes)
    other = load_leg(example_path("walker-leg-2.5"))
    assert leg.section("purple").design.H == (2.5, 2.5)
    assert leg.section("action").design == other.section("action").design
    assert leg.section("green").design.t == 0.9
    bad_ones = (
        ("purple.H", "SECTION.KEY=VALUE"),
        ("foot.H=2", "no such section"),
        ("purple.H=a", "numbers"),
        ("purple.X=1", "not a design key"),
    )
    for bad, message in bad_ones:
        with pytest.raises(ValueError, match=message):
            apply_assignments(leg, [bad])


# --- the command ----------------------------------------------------------------------------------


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("finger.simulate_leg",))
    return cli.main


def test_simulate_leg_json_and_plot(main, capsys, tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    import dpfexplore.plotting.leg as plotting

    drawn = spy(monkeypatch, plotting, "plot_tip_paths")
    png = tmp_path / "leg.png"
    assert main(["simulate-leg", "walker-leg", "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"tip_path", "sections", "fitted_range"} <= set(out)
    assert out["fitted_range"] is False
    assert out["sections"][0]["classes"] == ["no_contact", "no_contact"]
    assert out["sections"][0]["reset_times"] == [None, None]
    assert len(out["tip_path"]) == 501 and len(out["tip_path"][0]) == 4
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000
    # what is drawn: the JSON's tip path (t, x, y, z rows) in the x-y and y-z projections
    (axes,) = drawn
    assert_readable(axes[0].figure)
    path = np.array(out["tip_path"])[:, 1:]
    assert [(ax.get_xlabel(), ax.get_ylabel()) for ax in axes] == [
        ("tip x (mm)", "tip y (mm)"),
        ("tip y (mm)", "tip z (mm)"),
    ]
    for ax, (a, b) in zip(axes, ((0, 1), (1, 2)), strict=True):
        line = ax.get_lines()[0]  # the path; then its end marker and the start
        np.testing.assert_allclose(line.get_xdata(), path[:, a], atol=1e-6)
        np.testing.assert_allclose(line.get_ydata(), path[:, b], atol=1e-6)
    plt.close(axes[0].figure)


LEG = """
[leg]
t_end = 2.0
[phase.1]
P0 = 0.4
tau = [0.0, 0.1, 0.5, 0.6]
[[section]]
name = "a"
phase = "1"
design = {{ H = [3.0], U_L = 6.5, U_sep = 1.0, t = 1.0, t_lim = 1.0 }}
{extra}
"""


@pytest.mark.parametrize(
    "text, message",
    [
        (LEG.format(extra=""), "composition = 'dpw': needs exactly 3 sections"),
        (LEG.format(extra="[foo]\nx = 1"), "top level.foo: unknown key"),
        (LEG.format(extra="[[section]]\nphase = '2'\ndesign = {H = [3.0]}"), "section[2].design"),
        (
            LEG.format(extra="")
            .replace('phase = "1"', 'phase = "3"')
            .replace("t_end = 2.0", "t_end = 2.0\ncomposition = 'chain'"),
            "section[1].phase = '3': no such phase",
        ),
        (
            LEG.format(extra="").replace("t_end = 2.0", "t_end = 0.3\ncomposition = 'chain'"),
            "t_end = 0.3: phase '1' ends at 0.6 s",
        ),
        (
            LEG.format(extra="").replace("tau = [0.0, 0.1, 0.5, 0.6]", "tau = [0.0, 0.1]"),
            "phase.1.tau",
        ),
        (LEG.format(extra="").replace("t_end = 2.0", "t_end = 2.0\nmount = 3"), "[leg].mount"),
        ("[leg\n", "not valid TOML"),
    ],
)
def test_bad_leg_files(main, capsys, tmp_path, text, message):
    path = tmp_path / "leg.toml"
    path.write_text(text)
    assert main(["simulate-leg", str(path)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_missing_leg_file(main, capsys):
    assert main(["simulate-leg", "no-such-leg.toml"]) == 2
    assert "no such leg file" in capsys.readouterr().err


def test_the_leg_figure_names_the_leg_that_ran(main, capsys, tmp_path, monkeypatch):
    import dpfexplore.plotting.leg as plotting

    drawn = spy(monkeypatch, plotting, "plot_tip_paths")
    png = tmp_path / "leg.png"
    argv = ["simulate-leg", "walker-leg", "--set", "purple.t=0.9", "--plot", str(png)]
    assert main(argv) == 0
    capsys.readouterr()
    (axes,) = drawn
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert any("purple.t=0.9" in label for label in labels), labels
