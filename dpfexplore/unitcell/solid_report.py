"""The solid-versus-shell comparison of the cross-check: energies at matching apex travel.

:func:`compare` sets a solid curve (:mod:`dpfexplore.unitcell.solid_check`) beside the shell
model's first branch (:func:`shell_first_branch`, from
:func:`dpfexplore.unitcell.unit_cell_curve`) at matching apex travel. The cross-check's record,
``results/reports/unitcell-solid-check.json`` (closed-form checks, the domes, the
load-introduction sensitivity, the solid's mesh refinement), is written by
``scripts/unitcell_solid_check.py``.

Two figures are compared per dome, over the travel ``0.25 H ≤ δ ≤`` the first fold of either
model:

* **raw**: ``E_solid(δ) / E_shell(δ) − 1``;
* **series-corrected**: the shell's curve seen through a linear series spring of compliance
  ``Δc = 1/k_solid − 1/k_shell``, the difference of the two models' small-deflection apex
  compliances (each computed, nothing fitted to the curves): ``δ = δ_s + F Δc``,
  ``E = E_s + F² Δc / 2``. A shear-rigid shell under a point load and a solid loaded over a disc
  of radius ``a`` differ near the load by transverse shear and the load's spread (a compliance
  that depends on ``a`` like ``ln a``); if that local difference is what separates the curves,
  the corrected figure is small for every ``a`` while the raw one is not.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicHermiteSpline

from .solid_check import MeshSpec, SolidCurve

__all__ = ["DEFAULT_MESH", "LOW", "compare", "energy_spline", "shell_first_branch"]

#: The solid mesh of the cross-check: 30 elements along the meridian past the apex column,
#: 2 through the thickness, 2 across the column (quadratic elements; its refinement by 2 in
#: every direction is in the report).
DEFAULT_MESH = MeshSpec(n_along=30, n_through=2, n_disc=2, grading=1.1)
#: Start of the compared travel, in dome heights: below it both energies are tiny and the
#: ratio measures the initial stiffness only (reported apart).
LOW = 0.25


def shell_first_branch(H: float, t: float, r_b: float, E: float, nu: float) -> dict:
    """The shell model's stable first branch: travel (mm), energy (N·mm), force (N), fold (mm)."""
    from . import apex_stiffness, unit_cell_curve

    start, cpu_start = time.perf_counter(), time.process_time()
    run = unit_cell_curve(H, t, r_b, E, nu)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    first = (run.branch == 0) & run.stable
    d, unique = np.unique(run.displacement[first], return_index=True)
    return {
        "displacement": d,
        "energy": run.energy[first][unique],
        "force": run.force[first][unique],
        "fold": float(run.folds[0]) if run.folds.size else float(d[-1]),
        "stiffness": float(apex_stiffness(H, t, r_b, E, nu)),
        "elapsed": elapsed,
        "cpu": cpu,
        "n_elements": int(run.n_elements),
    }


def energy_spline(d: NDArray, e: NDArray, f: NDArray) -> CubicHermiteSpline:
    """Energy against travel with the force as its slope (exact for an equilibrium path)."""
    keep = np.concatenate([[True], np.diff(d) > 0])
    keep &= np.maximum.accumulate(d) <= d  # cut where the travel turns back
    return CubicHermiteSpline(d[keep], e[keep], f[keep])


def compare(solid: SolidCurve, shell: dict, k_solid: float) -> dict:
    """Energy of the solid against the shell's at matching apex travel.

    Parameters
    ----------
    solid : SolidCurve
    shell : dict
        From :func:`shell_first_branch`.
    k_solid : float, N/mm
        The solid's small-deflection apex stiffness (same mesh and load).

    Returns
    -------
    dict
        ``raw`` and ``series_corrected`` relative energy differences (max of the absolute value,
        mean, and the signed value at the end of the window), the window (mm), the folds (mm),
        the peak forces (N), the initial stiffnesses (N/mm) and ``delta_c`` (mm/N).
    """
    H = solid.H
    solid_end = solid.fold if solid.fold is not None else float(solid.displacement[-1])
    upto = min(solid_end, shell["fold"])
    d_s, e_s, f_s = shell["displacement"], shell["energy"], shell["force"]
    window = (solid.displacement >= LOW * H) & (solid.displacement <= upto)
    d = solid.displacement[window]
    e = solid.energy[window]
    raw = e / energy_spline(d_s, e_s, f_s)(d) - 1.0
    dc = 1.0 / k_solid - 1.0 / shell["stiffness"]
    spline_c = energy_spline(d_s + f_s * dc, e_s + 0.5 * f_s**2 * dc, f_s)
    inside = d <= spline_c.x[-1]
    corrected = e[inside] / spline_c(d[inside]) - 1.0

    def stats(x: NDArray) -> dict:
        return {
            "max_abs": float(np.abs(x).max()),
            "mean": float(x.mean()),
            "at_end": float(x[-1]),
            "points": int(x.size),
        }

    return {
        "window_mm": [float(d[0]), float(d[-1])],
        "raw": stats(raw),
        "series_corrected": stats(corrected),
        "fold_mm": {"solid": solid.fold, "shell": shell["fold"]},
        "solid_status": solid.status,
        "solid_last_travel_mm": float(solid.displacement[-1]),
        "peak_force_N": {"solid": float(solid.force.max()), "shell": float(f_s.max())},
        "initial_stiffness_N_per_mm": {"solid": k_solid, "shell": shell["stiffness"]},
        "delta_c_mm_per_N": dc,
    }
