"""The unit cell's independent cross-check: the solid against the shell, and its record.

Runs the closed-form checks (pinned plate, Reissner's shallow cap), five domes of the paper's box
as a 2-D axisymmetric solid beside the shell model
(:func:`dpfexplore.unitcell.solid_report.compare`), the load-introduction sensitivity, the
solid's mesh refinement and its material law, and writes the record
``results/reports/unitcell-solid-check.json`` that docs/guide/unitcell-crosscheck.md reads::

    .venv/bin/python scripts/unitcell_solid_check.py [OUT.json]   # about 3 min

Needs the ``crosscheck`` extra (scikit-fem).
"""

from __future__ import annotations

import json
import logging
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

from dpfexplore.unitcell import apex_stiffness
from dpfexplore.unitcell.checks import bending_length, plate_stiffness, shallow_shell_stiffness
from dpfexplore.unitcell.solid_check import MeshSpec, SolidCurve, solid_curve, solid_stiffness
from dpfexplore.unitcell.solid_report import (
    DEFAULT_MESH,
    LOW,
    compare,
    energy_spline,
    shell_first_branch,
)

logger = logging.getLogger("unitcell_solid_check")


def _solid(
    H, t, r_b, E, nu, mesh, a, apex, n_steps, material="neo-hookean"
) -> tuple[SolidCurve, float]:
    curve = solid_curve(
        H,
        t,
        r_b,
        E,
        nu,
        n_steps=n_steps,
        mesh=mesh,
        disc_radius=a,
        apex=apex,
        material=material,
    )
    k = solid_stiffness(H, t, r_b, E, nu, mesh=mesh, disc_radius=a, apex=apex)
    return curve, k


def _curve_record(curve: SolidCurve) -> dict:
    return {
        "status": curve.status,
        "fold_mm": curve.fold,
        "n_dofs": curve.n_dofs,
        "points": int(curve.displacement.size),
        "elapsed_s": round(curve.elapsed, 2),
        "cpu_s": round(curve.cpu, 2),
        "displacement_mm": np.round(curve.displacement, 6).tolist(),
        "energy_Nmm": np.round(curve.energy, 6).tolist(),
        "force_N": np.round(curve.force, 6).tolist(),
    }


def _mindlin_plate_excess(E: float, nu: float, t: float, r_b: float, a: float) -> float:
    """Transverse-shear compliance of a pinned plate loaded over radius ``a`` (mm/N).

    Mindlin's correction to the Kirchhoff centre deflection, ``P/(2π κ G t) ln(r_b/a)`` with
    ``κ = 5/6`` (leading order in ``a/r_b``); an estimate of what the solid adds.
    """
    G = E / (2.0 * (1.0 + nu))
    return math.log(r_b / a) / (2.0 * math.pi * (5.0 / 6.0) * G * t)


def build_report(
    out: str | Path = "results/reports/unitcell-solid-check.json",
    *,
    domes: tuple[tuple[float, float], ...] = (
        (3.0, 1.0),
        (4.0, 1.0),
        (3.0, 0.8),
        (5.0, 1.0),
        (3.0, 0.5),
    ),
    n_steps: int = 30,
) -> dict:
    """Run the cross-check and write its record (JSON) to ``out``; returns the record."""
    r_b, E, nu = 5.0, 26.0, 0.35
    record: dict = {
        "what": "2-D axisymmetric solid (scikit-fem) against the shell model",
        "command": "python scripts/unitcell_solid_check.py",
        "machine": {
            "uname_m": platform.machine(),
            "cpu_count": os.cpu_count(),
            "load_average_at_start": os.getloadavg()[0],
        },
        "software": {"python": sys.version.split()[0], "scikit-fem": _version("scikit-fem")},
        "material": {"law": "compressible neo-Hookean", "E_MPa": E, "nu": nu},
        "mesh": vars(DEFAULT_MESH),
        "load": "apex column s <= a through the thickness, u_z = -delta (apex='column')",
        "edge": "mean position of the edge face held (length-weighted), rotation free",
    }
    # closed forms: pinned plate (thin and thick), Reissner's shallow cap
    plates = []
    for t in (0.1, 0.2, 0.5, 1.0):
        k_plate = plate_stiffness(E, nu, t, r_b)
        row = {"t_mm": t, "kirchhoff_N_per_mm": k_plate}
        for apex in ("column", "mean"):
            k = solid_stiffness(0.0, t, r_b, E, nu, mesh=MeshSpec(40, 2, 2, 1.1), apex=apex)
            row[f"solid_{apex}_N_per_mm"] = k
            row[f"solid_{apex}_rel"] = k / k_plate - 1.0
        mindlin = 1.0 / (1.0 / k_plate + _mindlin_plate_excess(E, nu, t, r_b, 0.5 * t))
        row["kirchhoff_plus_mindlin_shear_rel"] = mindlin / k_plate - 1.0
        plates.append(row)
    record["plate"] = plates
    t_c, R_c = 0.05, 10.0
    ell = bending_length(R_c, t_c, nu)
    caps = []
    for n_ell in (10.0, 16.0):
        rb = n_ell * ell
        H_c = R_c - math.sqrt(R_c**2 - rb**2)
        k_r = shallow_shell_stiffness(E, nu, t_c, R_c)
        spec = MeshSpec(max(40, int(4 * rb / t_c) // 8), 2, 2, 1.1)
        k_sh = apex_stiffness(H_c, t_c, rb, E, nu)
        row = {
            "R_mm": R_c,
            "t_mm": t_c,
            "r_b_over_ell": n_ell,
            "H_over_r_b": H_c / rb,
            "reissner_N_per_mm": k_r,
            "shell_rel": k_sh / k_r - 1.0,
            "mesh_n_along": spec.n_along,
        }
        for apex in ("column", "mean"):
            k = solid_stiffness(H_c, t_c, rb, E, nu, mesh=spec, apex=apex)
            row[f"solid_{apex}_rel"] = k / k_r - 1.0
        caps.append(row)
    record["reissner"] = caps
    # the domes
    rows = []
    for H, t in domes:
        shell = shell_first_branch(H, t, r_b, E, nu)
        curve, k = _solid(H, t, r_b, E, nu, DEFAULT_MESH, 0.5 * t, "column", n_steps)
        k_mean = solid_stiffness(H, t, r_b, E, nu, mesh=DEFAULT_MESH, apex="mean")
        rows.append(
            {
                "H_mm": H,
                "t_mm": t,
                "a_mm": 0.5 * t,
                **compare(curve, shell, k),
                "initial_stiffness_solid_mean_load_N_per_mm": k_mean,
                "shell_elapsed_s": round(shell["elapsed"], 3),
                "shell_cpu_s": round(shell["cpu"], 3),
                "shell_elements": shell["n_elements"],
                "solid": _curve_record(curve),
            }
        )
        logger.info("dome H=%g t=%g done", H, t)
    record["domes"] = rows
    # load introduction: radius and kind, on the thickest low dome
    H, t = domes[0]
    shell = shell_first_branch(H, t, r_b, E, nu)
    sens = []
    for apex, a in (("column", 0.25 * t), ("column", t), ("mean", 0.5 * t), ("mean", t)):
        curve, k = _solid(H, t, r_b, E, nu, DEFAULT_MESH, a, apex, n_steps)
        sens.append(
            {
                "apex": apex,
                "a_mm": a,
                **compare(curve, shell, k),
                "elapsed_s": curve.elapsed,
                "cpu_s": curve.cpu,
            }
        )
    record["load_sensitivity"] = {"H_mm": H, "t_mm": t, "runs": sens}
    # the solid's own mesh convergence
    fine = DEFAULT_MESH.refined()
    coarse_curve, _ = _solid(H, t, r_b, E, nu, DEFAULT_MESH, 0.5 * t, "column", n_steps)
    fine_curve, _ = _solid(H, t, r_b, E, nu, fine, 0.5 * t, "column", n_steps)
    # a level below the default (half the elements along, one across the column) for the trend
    coarser = MeshSpec(DEFAULT_MESH.n_along // 2, DEFAULT_MESH.n_through, 1, DEFAULT_MESH.grading)
    coarser_curve, _ = _solid(H, t, r_b, E, nu, coarser, 0.5 * t, "column", n_steps)
    upto = min(c.displacement[-1] for c in (coarse_curve, fine_curve, coarser_curve))
    grid = coarse_curve.displacement[
        (coarse_curve.displacement >= LOW * H) & (coarse_curve.displacement <= upto)
    ]
    e_fine = energy_spline(fine_curve.displacement, fine_curve.energy, fine_curve.force)(grid)
    e_coarse = energy_spline(coarse_curve.displacement, coarse_curve.energy, coarse_curve.force)(
        grid
    )
    e_coarser = energy_spline(
        coarser_curve.displacement, coarser_curve.energy, coarser_curve.force
    )(grid)
    # the law: SVK (Green-Lagrange) against neo-Hookean on the same mesh and load
    svk, _ = _solid(H, t, r_b, E, nu, DEFAULT_MESH, 0.5 * t, "column", n_steps, "svk")
    common = coarse_curve.displacement[
        (coarse_curve.displacement > 0) & (coarse_curve.displacement <= svk.displacement[-1])
    ]
    e_svk = energy_spline(svk.displacement, svk.energy, svk.force)(common)
    e_nh = energy_spline(coarse_curve.displacement, coarse_curve.energy, coarse_curve.force)(common)
    drops = np.flatnonzero(np.diff(svk.energy) < 0.0)
    record["svk"] = {
        "H_mm": H,
        "t_mm": t,
        "status": svk.status,
        "last_travel_mm": float(svk.displacement[-1]),
        "first_energy_drop_mm": float(svk.displacement[drops[0] + 1]) if drops.size else None,
        "energy_rel_to_neo_hookean": {
            f"{x:.3g}": float(y)
            for x, y in zip(common[::4], (e_svk / e_nh - 1.0)[::4], strict=True)
        },
    }
    record["mesh_refinement"] = {
        "H_mm": H,
        "t_mm": t,
        "what": "energy against the fine mesh's over 0.25 H <= delta <= the first fold",
        "coarser": {
            **vars(coarser),
            "n_dofs": coarser_curve.n_dofs,
            "fold_mm": coarser_curve.fold,
            "cpu_s": coarser_curve.cpu,
            "energy_max_abs_rel": float(np.abs(e_coarser / e_fine - 1.0).max()),
        },
        "coarse": {
            **vars(DEFAULT_MESH),
            "n_dofs": coarse_curve.n_dofs,
            "fold_mm": coarse_curve.fold,
            "elapsed_s": coarse_curve.elapsed,
            "cpu_s": coarse_curve.cpu,
        },
        "fine": {
            **vars(fine),
            "n_dofs": fine_curve.n_dofs,
            "fold_mm": fine_curve.fold,
            "elapsed_s": fine_curve.elapsed,
            "cpu_s": fine_curve.cpu,
        },
        "energy_max_abs_rel": float(np.abs(e_coarse / e_fine - 1.0).max()),
    }
    domes_ = record["domes"]
    record["summary"] = {
        "what": (
            "over the domes: largest |E_solid/E_shell - 1| for 0.25 H <= delta <= first fold, "
            "largest relative difference of the first fold's travel and of the peak force"
        ),
        "energy_max_abs_rel": max(d["raw"]["max_abs"] for d in domes_),
        "fold_max_abs_rel": max(
            abs(d["fold_mm"]["solid"] / d["fold_mm"]["shell"] - 1.0)
            for d in domes_
            if d["fold_mm"]["solid"] is not None
        ),
        "peak_force_max_abs_rel": max(
            abs(d["peak_force_N"]["solid"] / d["peak_force_N"]["shell"] - 1.0) for d in domes_
        ),
        "load_sensitivity_energy_max_abs_rel": [
            min(r["raw"]["max_abs"] for r in sens),
            max(r["raw"]["max_abs"] for r in sens),
        ],
    }
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(record, indent=1) + "\n")
    tmp.replace(path)
    return record


def _version(name: str) -> str:
    from importlib.metadata import version

    return version(name)


def main(argv: list[str] | None = None) -> int:
    """Write the record to ``argv[0]`` (default: results/reports/unitcell-solid-check.json)."""
    argv = sys.argv[1:] if argv is None else argv
    logging.basicConfig(level=logging.WARNING)
    logger.setLevel(logging.INFO)  # this script's progress, not scikit-fem's per-assembly lines
    build_report(*argv[:1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
