"""The design summaries as a user reads them: which design answers a position-and-stiffness
target, and a fitted-range warning under the design it concerns."""

from __future__ import annotations

import math
from pathlib import Path

from dpfexplore.inverse.kinds import load_scene
from dpfexplore.inverse.scenes.gripper.summary import summary_lines as gripper_lines
from dpfexplore.inverse.scenes.position.summary import summary_lines as position_lines

JOBS = Path(__file__).parents[2] / "jobs"


def _rung(tolerance, distance, stiffness, n):
    return {
        "tolerance_mm": tolerance,
        "distance_mm": distance,
        "stiffness": stiffness,
        "n_units": n,
    }


def test_position_stiffness_names_the_stiffest_design_within_the_scene_tolerance():
    spec = load_scene(JOBS / "design-position-stiffness.toml")
    within = math.sqrt(spec.kind_spec.tolerance)  # 1e-6 mm²: met within 0.001 mm
    row = {
        "target": [46.0, 32.0],
        "n_units": 5,
        "tip": [46.0, 32.0],
        "objective": 2.25e-12,
        "stiffness": 0.05483,  # the closest design, found before stiffness is asked for
        "evaluations": {"designs": 10},
        "wall_s": 1.0,
        "reachable": True,
        "fitted_range": True,
        "front": [
            _rung(0.0005, 4e-4, 0.1600, 4),
            _rung(within, 8.1e-4, 0.1711, 4),
            _rung(0.01, 9e-3, 0.1900, 6),  # stiffer, but outside the scene's tolerance
        ],
    }
    lines = position_lines(spec, [row])
    assert max(len(line) for line in lines) <= 100
    (at,) = [i for i, line in enumerate(lines) if line.lstrip().startswith("answer:")]
    answer = " ".join(lines[at : at + 2])
    assert "N 4, 0.1711 N/mm" in answer and "front[1]" in answer
    assert "0.00081 mm from the target" in answer and "(0.001 mm" in answer
    front = " ".join(
        line for line in lines if "front (tol" in line or line.startswith(" " * 8 + "0")
    )
    assert "0.01: 0.1900" in front


def test_gripper_warning_stands_under_its_design():
    spec = load_scene(JOBS / "design-gripper.toml")
    note = "H[unit 5] = 2.33439 mm below the fitted 3-5 mm"
    row = {
        "apertures": [70.0, 60.0, 45.0, 35.0],
        "target": [70.0, 60.0, 45.0, 35.0],
        "theta_B_deg": -45.0,
        "base_L": 10.62,
        "stiffness": 0.0945,
        "metastability": {"reset_time_s": 0.69, "ok": True},
        "pressure_windows_kPa": [(66.1, 92.6)],
        "windows_ok": True,
        "pressure_windows_kPa_detail": {"note": "quasi-static"},
        "reference": {"apertures": [77.1, 60.0, 44.9, 35.0], "stiffness": 0.0397},
        "fitted_range": False,
        "fitted_range_note": note,
    }
    lines = gripper_lines(spec, [row])
    assert lines[0].startswith(
        "  apertures 70.000, 60.000, 45.000, 35.000 mm (targets 70, 60, 45, 35)"
    )
    assert lines[1].startswith("  warning: the design lies outside") and note in lines[1]
    assert lines[-1].startswith("  reference:")
