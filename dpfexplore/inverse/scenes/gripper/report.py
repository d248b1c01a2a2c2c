"""The gripper scene's verified result and the files it writes.

The reported gripper (and the scene's reference, if any) is re-solved alone in every grasp state
by :func:`~dpfexplore.inverse.report.verify_state`; the apertures and stiffness reported are those
re-solves'. Its metastability (a full-model run of the pulse) and pressure windows (the snap
continuation) come with it.

Files (:func:`write_gripper_report`)
    ``summary.json``, ``history.parquet``   as :func:`dpfexplore.inverse.report.write_summary`
    ``gripper.toml``          the gripper's design as a ``[design]`` table (``dpfexplore states``
                              reads it back) with its base and apertures in ``[result]``
    ``*.png``                 with ``plot=True``: the objective against evaluations and the
                              gripper in its grasp states
    ``sorting-objects.csv``   with ``[gripper.sorting]``: the objects the re-verification
                              sorted (true class: the class's outcome); with ``plot=True``
                              ``sorting.png``, the sorting map with the classes' boxes
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ....lookup.files import write_constants_beside
from ....model.design import Design
from ....model.formatting import json_number
from ....model.gripper import gripper_aperture
from ....solvers.lattice import spring_constants
from ...evaluation import SceneEvaluator
from ...report import VERIFIED_BY, verify_state, write_result_row, write_summary
from ...spec import SceneSpec
from .solve import GripperTargetResult, Metastability, metastability, windows_ok
from .sorting_check import SortingVerification, verify_sorting
from .sorting_stage import SortingTargetResult
from .spec import GripperSpec
from .windows import PressureWindows, pressure_windows

__all__ = [
    "GripperDesign",
    "GripperReference",
    "GripperResult",
    "gripper_report",
    "verified_gripper",
    "write_gripper_report",
]


@dataclass(frozen=True)
class GripperDesign:
    """A gripper (finger and base) re-solved alone in every grasp state.

    Attributes
    ----------
    design : Design
    theta_B_deg : float
        Base angle, degrees.
    base_L : float
        Base length, mm.
    apertures, aperture_errors : tuple of float
        Aperture of each grasp state and its difference from the target, mm.
    stiffness : float
        Tip stiffness of the activated state, N/mm.
    state : str
        The activated state.
    statuses : tuple of str
        Status of each re-solved state (the grasp states, then the activated one if not one of
        them).
    nodes : tuple of ndarray
        The finger's nodes in each grasp state, mm (for figures).
    h : float
        Height of the finger's base segment, mm (for figures).
    """

    design: Design
    theta_B_deg: float
    base_L: float
    apertures: tuple[float, ...]
    aperture_errors: tuple[float, ...]
    stiffness: float
    state: str
    statuses: tuple[str, ...]
    nodes: tuple[NDArray, ...]
    h: float

    @property
    def stable(self) -> bool:
        """Every re-solved state is stable."""
        return all(s == "ok" for s in self.statuses)

    def to_dict(self) -> dict[str, Any]:
        """The gripper's part of a ``--json`` row."""
        errors = list(self.aperture_errors)
        return {
            "design": self.design.to_dict(),
            "n_units": self.design.n_units,
            "theta_B_deg": self.theta_B_deg,
            "base_L": self.base_L,
            "apertures": list(self.apertures),
            "aperture_errors": errors,
            "stiffness": json_number(self.stiffness),
            "state": self.state,
            "objective": float(np.sum(np.square(errors))),
            "fitted_range": bool(self.design.in_fitted_range),
            "fitted_range_note": self.design.fitted_range_note,
            "verification": {
                "method": VERIFIED_BY,
                "status": list(self.statuses),
                "stable": self.stable,
            },
        }


@dataclass(frozen=True)
class GripperReference:
    """The scene's reference gripper, verified as a result is.

    Attributes
    ----------
    gripper : GripperDesign
    metastability : Metastability
    pressure_windows_kPa : list
        One ``[P_enter, P_leave]`` (kPa) per grasp state, None where no release ends in it.
    """

    gripper: GripperDesign
    metastability: Metastability
    pressure_windows_kPa: list[list[float] | None]

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` entry."""
        return {
            **self.gripper.to_dict(),
            "metastability": self.metastability,
            "pressure_windows_kPa": self.pressure_windows_kPa,
        }


@dataclass(frozen=True)
class GripperResult:
    """The gripper scene's one result, verified (the ``--json`` row of :meth:`to_dict`).

    Attributes
    ----------
    target : tuple of float
        The target apertures, mm.
    reachable : bool
        Every state re-solved stable with its aperture within the tolerance.
    gripper : GripperDesign
    windows : PressureWindows or empty
        The pressure windows of its grasp states, kPa.
    windows_ok : bool or None
        Every window met in order and wide enough (None: not computed).
    metastability : Metastability or empty
        Its pulse run (empty when no finalist met the apertures).
    evaluations : dict of str to int
    wall_s : float
        Seconds of the search.
    reference : GripperReference or None
    sorting : SortingVerification or None
        The sorting objective's re-verification (with ``[gripper.sorting]``).
    """

    target: tuple[float, ...]
    reachable: bool
    gripper: GripperDesign
    windows: PressureWindows | dict
    windows_ok: bool | None
    metastability: Metastability | dict
    evaluations: dict[str, int]
    wall_s: float
    reference: GripperReference | None = None
    sorting: SortingVerification | None = None

    @property
    def met(self) -> bool:
        """Apertures met, windows not refused and, when simulated, the tip unit metastable.

        With a sorting objective, also every class sorted correctly by the re-verification.
        """
        checks = self.metastability
        return (
            self.reachable
            and self.windows_ok is not False
            and not (checks and not checks.get("ok", True))
            and (self.sorting is None or self.sorting.met)
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row."""
        entry = self.gripper.to_dict()
        row: dict[str, Any] = {
            "target": list(self.target),
            "reachable": self.reachable,
            **entry,
            "pressure_windows_kPa": self.windows.get("windows"),
            "pressure_windows_kPa_detail": self.windows,
            "windows_ok": self.windows_ok,
            "metastability": self.metastability,
            "evaluations": dict(self.evaluations),
            "wall_s": self.wall_s,
        }
        if self.reference is not None:
            ref = self.reference.to_dict()
            row["reference"] = ref
            if ref["stiffness"] is not None and entry["stiffness"] is not None:
                row["stiffness_ratio_to_reference"] = entry["stiffness"] / ref["stiffness"]
        if self.sorting is not None:
            row["sorting"] = self.sorting.to_dict()
        return row


def verified_gripper(
    design: Design, g: GripperSpec, theta: float, base_l: float, evaluator: SceneEvaluator
) -> GripperDesign:
    """``design`` on the base ``theta`` (degrees), ``base_l`` (mm), re-solved in every state."""
    h = float(spring_constants(design).h)
    apertures, stiffness, statuses, nodes = [], math.nan, [], []
    for state in dict.fromkeys([*g.states, g.activated]):
        check = verify_state(design, state, evaluator)
        statuses.append(check.status)
        if state in g.states:
            apertures.append(float(gripper_aperture(list(check.tip), h, base_l, theta)))
            nodes.append(check.nodes)
        if state == g.activated:
            stiffness = check.stiffness
    errors = [a - t for a, t in zip(apertures, g.apertures, strict=True)]
    return GripperDesign(
        design=design,
        theta_B_deg=theta,
        base_L=base_l,
        apertures=tuple(apertures),
        aperture_errors=tuple(errors),
        stiffness=stiffness,
        state=g.activated,
        statuses=tuple(statuses),
        nodes=tuple(nodes),
        h=h,
    )


def gripper_report(
    spec: SceneSpec[GripperSpec], result: GripperTargetResult, evaluator: SceneEvaluator
) -> GripperResult:
    """The verified result of the gripper scene."""
    g = spec.kind_spec
    if isinstance(result, SortingTargetResult) and result.apertures:
        g = replace(g, apertures=result.apertures)  # the apertures the sorting objective chose
    best = result.best
    design = best.problem.designs(np.atleast_2d(best.z)).design(0)
    theta, base_l = (float(v[0]) for v in best.problem.base(np.atleast_2d(best.z)))
    gripper = verified_gripper(design, g, theta, base_l, evaluator)
    windows = result.windows
    met = gripper.stable and max(abs(e) for e in gripper.aperture_errors) <= g.aperture_tol
    window_ok = windows_ok(windows, g.min_window_kPa) if windows.get("computed") else None
    reference = None
    if g.reference is not None and g.reference_theta_B_deg is not None:
        ref = verified_gripper(
            g.reference, g, g.reference_theta_B_deg, g.reference_base_L, evaluator
        )
        reference = GripperReference(
            gripper=ref,
            metastability=metastability(g.reference, g, evaluator),
            pressure_windows_kPa=pressure_windows(g.reference, g.states, evaluator)["windows"],
        )
    verified = GripperResult(
        target=tuple(g.apertures),
        reachable=bool(met),
        gripper=gripper,
        windows=windows,
        windows_ok=window_ok,
        metastability=result.metastability,
        evaluations=dict(result.counts),
        wall_s=result.wall_s,
        reference=reference,
    )
    if g.sorting is None:
        return verified
    search = result.sorting if isinstance(result, SortingTargetResult) else None
    sorting = verify_sorting(
        verified.to_dict(),
        g.sorting,
        title=_title(spec, list(g.apertures)),
        constants=spec.constants,
        scene_apertures=tuple(spec.kind_spec.apertures),
        apertures=tuple(g.apertures),
        default_margin=search.default.margin if search and search.default else math.nan,
        evaluations=search.evaluations if search else 0,
        trace=search.trace if search else [],
    )
    return replace(verified, sorting=sorting)


def _title(spec: SceneSpec, target: list) -> str:
    return f"{spec.name}: gripper, apertures {target} mm"


# ----------------------------------------------------------------------------- files


def write_gripper_report(
    spec: SceneSpec[GripperSpec],
    results: list[GripperResult],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    plot: bool = False,
) -> list[Path]:
    """Write summary, history, ``gripper.toml`` and (optionally) figures; returns the paths.

    Writes into ``out`` as it stands: :func:`dpfexplore.inverse.design.run_design` passes the
    staging directory of :func:`dpfexplore.io.result_dirs.result_directory`, so the
    report appears complete or not at all.
    """
    out = Path(out)
    history = evaluator.history()
    rows = [r.to_dict() for r in results]
    written = write_summary(spec, rows, evaluator, out, wall_s=wall_s, history=history)
    for row in rows:
        path = out / "gripper.toml"
        title = _title(spec, row["target"])
        write_result_row(path, row, title=title, constants=spec.constants)
        written.append(path)
    for result in results:
        if result.sorting is not None:
            written += _sorting_files(result, out)
    written += write_constants_beside(spec.constants, out)
    if plot:
        written += _figures(spec.kind_spec, results, history, out)
        written += [_sorting_figure(r, out) for r in results if r.sorting is not None]
    return written


def _sorting_files(result: GripperResult, out: Path) -> list[Path]:
    """The re-verification's objects as a CSV ``sort`` reads; the design file checked."""
    import csv
    import io

    from ....grasping.sort import read_objects
    from ....io.files import atomic_write
    from ....model.design import load_design

    # the file the report leaves is the one the re-verification read back and sorted
    verified = result.sorting.report.gripper.design
    if load_design(out / "gripper.toml").to_dict() != verified.to_dict():
        raise RuntimeError(f"{out / 'gripper.toml'}: does not read back as the verified design")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["name", "diameter", "mass", "class"])
    for o in result.sorting.report.objects:
        writer.writerow([o.name, repr(o.diameter_mm), repr(o.mass_kg), o.true_class])
    path = out / "sorting-objects.csv"
    atomic_write(path, buffer.getvalue().encode())
    if read_objects(path).classes != tuple(o.true_class for o in result.sorting.report.objects):
        raise RuntimeError(f"{path}: does not read back as written")
    return [path]


def _sorting_figure(result: GripperResult, out: Path) -> Path:
    """The sorting map of the verified gripper with the classes' boxes (``sorting.png``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .sorting_plot import plot_sorting_result

    ax = plot_sorting_result(result.sorting)
    path = out / "sorting.png"
    ax.figure.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(ax.figure)
    return path


def _figures(g: GripperSpec, results: list[GripperResult], history, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ....plotting.design import plot_gripper, plot_objective_history

    paths = []

    def save(ax_or_fig, name: str) -> None:
        fig = getattr(ax_or_fig, "figure", ax_or_fig)
        path = out / name
        fig.savefig(path, dpi=130, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)

    save(plot_objective_history(history), "objective.png")
    gripper = results[0].gripper
    save(
        plot_gripper(
            list(gripper.nodes),
            gripper.h,
            gripper.theta_B_deg,
            gripper.base_L,
            list(g.apertures),
            list(gripper.apertures),
            states=list(g.states),
        ),
        "gripper.png",
    )
    return paths
