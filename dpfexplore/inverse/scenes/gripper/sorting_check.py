"""The sorting objective's verification: the written design re-solved and sorted.

The reported gripper is written as its design file (``gripper.toml``: ``[design]`` and the base
in ``[result]``, as :func:`~dpfexplore.inverse.report.write_result_row` writes it), read back,
solved again in its grasp states (:func:`dpfexplore.grasping.gripper_of` on the base read from
the file), its classes' margins computed by the loop, and :func:`dpfexplore.grasping.sort_objects`
run on objects sampled from every class (:func:`~dpfexplore.grasping.classes.class_samples`:
5 diameters x 3 masses per class, the box's edges and centre lines included). The objective is
met only when every sample of every class gets its class's outcome (the loop's at the class's
centre), held, and no two classes share one.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ....grasping.classes import ObjectClass, SortingMargins, class_samples
from ....grasping.setup import gripper_of
from ....grasping.sort import Objects, SortReport, sort_objects
from ....io.toml_fields import read_toml
from ....model.design import load_design
from ...report import write_result_row
from .sorting import SortingSpec
from .sorting_search import loop_margins

__all__ = ["SortingVerification", "verify_sorting"]

#: Samples per class: diameters and masses, edges included.
SAMPLES = (5, 3)
#: The confusion table's column of samples wider than the open gripper (not sorted).
WIDER = "wider than the open gripper"


@dataclass(frozen=True)
class SortingVerification:
    """The sorting objective of a verified gripper (the ``sorting`` entry of its row).

    Attributes
    ----------
    classes : tuple of ObjectClass
    scene_apertures, apertures : tuple of float
        The apertures ``[gripper]`` asks for, and the ones the design chose (mm).
    default_margin : float
        The loop's margin of the scene's own design (dimensionless; NaN when not computed).
    margins : SortingMargins
        The reported design's, re-solved from its written file.
    report : SortReport
        ``sort_objects`` on the classes' samples (true class: the class's outcome).
    confusion : dict
        ``{class name: {outcome: count}}``.
    correct : dict of str to bool
        Per class: every sample got the class's outcome, held, of its own.
    evaluations : int
        Margins the search computed.
    trace : list of (apertures, margin)
    """

    classes: tuple[ObjectClass, ...]
    scene_apertures: tuple[float, ...]
    apertures: tuple[float, ...]
    default_margin: float
    margins: SortingMargins
    report: SortReport
    confusion: dict[str, dict[str, int]]
    correct: dict[str, bool]
    evaluations: int
    trace: list

    @property
    def met(self) -> bool:
        """Every class's samples classified correctly by the re-verification."""
        return all(self.correct.values())

    def to_dict(self) -> dict[str, Any]:
        """The ``sorting`` entry of the ``--json`` row."""
        return {
            "met": self.met,
            "scene_apertures": list(self.scene_apertures),
            "apertures": list(self.apertures),
            "default_margin": None if math.isnan(self.default_margin) else self.default_margin,
            **self.margins.to_dict(),
            "mu": self.report.mu,
            "lift_s": self.report.lift_s,
            "tip_reset_s": None if math.isnan(self.report.tip_reset_s) else self.report.tip_reset_s,
            "tip_lasts": self.report.tip_lasts,
            "samples_per_class": SAMPLES[0] * SAMPLES[1],
            "confusion": self.confusion,
            "correct": self.correct,
            "accuracy": self.report.accuracy,
            "search": {
                "evaluations": self.evaluations,
                "trace": [[a, None if math.isnan(m) else m] for a, m in self.trace],
            },
        }


def verify_sorting(
    row: dict[str, Any],
    sorting: SortingSpec,
    *,
    title: str,
    constants=None,
    scene_apertures: tuple[float, ...],
    apertures: tuple[float, ...],
    default_margin: float,
    evaluations: int,
    trace: list,
) -> SortingVerification:
    """Write ``row``'s design file, read it back, re-solve it and sort the classes' samples."""
    with tempfile.TemporaryDirectory(prefix="dpfexplore-sorting-") as tmp:
        path = write_result_row(Path(tmp) / "gripper.toml", row, title=title, constants=constants)
        design = load_design(path)
        result = read_toml(path, "design")["result"]
    gripper = gripper_of(
        design, base_L=float(result["base_L"]), theta_B_deg=float(result["theta_B_deg"])
    )
    from ....grasping.grasp import tip_reset_time

    lasts = bool(tip_reset_time(design) >= sorting.lift_s)
    margins = loop_margins(gripper, sorting, lasts)
    expected = {m.name: m.label for m in margins.classes}
    samples = class_samples(sorting.classes, *SAMPLES)
    fits = samples.diameters <= gripper.open_aperture  # wider objects cannot be sorted
    objects = Objects(
        tuple(n for n, f in zip(samples.names, fits, strict=True) if f),
        samples.diameters[fits],
        samples.masses[fits],
        tuple(expected[name] for name, f in zip(samples.classes, fits, strict=True) if f),
    )
    report = sort_objects(gripper, objects, mu=sorting.mu, lift_s=sorting.lift_s)
    confusion: dict[str, dict[str, int]] = {name: {} for name in expected}
    outcomes = iter(report.objects)
    for name, fit in zip(samples.classes, fits, strict=True):
        label = next(outcomes).label if fit else WIDER
        confusion[name][label] = confusion[name].get(label, 0) + 1
    labels = list(expected.values())
    correct = {
        name: (
            set(confusion[name]) == {label}
            and labels.count(label) == 1
            and not label.endswith("/not_held")
            and not label.startswith("none/")
        )
        for name, label in expected.items()
    }
    return SortingVerification(
        classes=tuple(sorting.classes),
        scene_apertures=tuple(scene_apertures),
        apertures=tuple(apertures),
        default_margin=default_margin,
        margins=margins,
        report=report,
        confusion=confusion,
        correct=correct,
        evaluations=evaluations,
        trace=trace,
    )
