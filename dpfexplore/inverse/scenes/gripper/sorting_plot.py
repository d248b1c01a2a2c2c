"""The sorting objective's figure: the sorting map of the verified gripper with the classes."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes

from ....grasping.sort import WEIGHT_CLASSES, report_map
from ....plotting.grasp import plot_sorting_map
from .sorting_check import SortingVerification

__all__ = ["plot_sorting_result"]

#: Grid of the map: diameters x masses.
GRID = (100, 100)


def plot_sorting_result(verification: SortingVerification, ax: Axes | None = None) -> Axes:
    """The loop's classes over (diameter, mass), the classes' boxes and the sorted samples.

    The map (:func:`dpfexplore.grasping.sorting_map`) spans half the smallest class's lower
    diameter to the open gripper's aperture (mm) and 0 to 1.5 times the heaviest class's upper
    mass (drawn in g), at the re-verification's friction, tip unit and threshold; each class is
    a labelled rectangle (a line when its mass is one value), the samples black crosses.
    """
    from matplotlib.patches import Rectangle

    report = verification.report
    gripper = report.gripper
    classes = verification.margins.classes
    boxes = {c.name: c for c in verification.classes}
    smallest = min(b.diameter[0] for b in boxes.values())
    heaviest = max(b.mass[1] for b in boxes.values())
    diameters, masses, size, weight = report_map(report, smallest, heaviest, GRID)
    ax = plot_sorting_map(
        diameters,
        masses,
        size,
        weight,
        states=gripper.states,
        weight_classes=WEIGHT_CLASSES,
        objects=(
            np.array([o.diameter_mm for o in report.objects]),
            np.array([o.mass_kg for o in report.objects]),
        ),
        ax=ax,
    )
    for c in classes:
        box = boxes[c.name]
        (d0, d1), (m0, m1) = box.diameter, box.mass
        ok = verification.correct[c.name]
        ax.add_patch(
            Rectangle(
                (d0, 1e3 * m0),
                d1 - d0,
                1e3 * (m1 - m0),
                fill=False,
                edgecolor="k" if ok else "r",
                linewidth=1.5,
                linestyle="-" if ok else ":",
                label=f"class {c.name}",
            )
        )
        ax.annotate(
            f"{c.name}\n{c.margin:.2g}",
            (0.5 * (d0 + d1), 1e3 * m1),
            textcoords="offset points",
            xytext=(0, 3),
            ha="center",
            va="bottom",
            fontsize="x-small",
            color="k" if ok else "r",
        )
    ax.set_title(
        f"Sorting map of the design: margin {verification.margins.margin:.3g} "
        f"({'every class sorted' if verification.met else 'NOT every class sorted'})",
        fontsize="small",
    )
    return ax
