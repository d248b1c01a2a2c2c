"""What :func:`~.validate.validate` reports: per finger and set, per set and material, verdicts.

Frozen records with their units in the docstrings; ``to_dict`` gives the JSON form (``--json``),
whose ``units`` table (:data:`UNITS`) names the unit of every quantity. Lengths in mm, stiffness
in N/mm; a relative distance is the tip distance over the measured tip's distance from the base.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model.formatting import json_number

__all__ = ["UNITS", "FingerResult", "Goal", "SetSummary", "SetVerdict", "Validation"]

#: Units of the quantities in the JSON form (``"1"``: dimensionless).
UNITS = {
    "tip": "mm",
    "distance": "mm",
    "relative_distance": "1",
    "stiffness": "N/mm",
    "stiffness_ratio": "1 (predicted / measured)",
    "stiffness_error": "1 (predicted / measured - 1)",
}


def _point(value: tuple[float, float] | None) -> list | None:
    return None if value is None else [json_number(v) for v in value]


@dataclass(frozen=True)
class FingerResult:
    """One printed finger under one constants set: the prediction beside the measurement.

    Attributes
    ----------
    finger, material : str
        The measurement's name and material (:attr:`.fingers.Measurement.material_label`).
    constants, fingerprint : str
        The set's name and fingerprint.
    requested, found : str
        The measured state and the one the state search settled in ("" for none).
    status : str
        The search's :class:`~dpfexplore.model.status.Status` label (``ok``, ``collapsed``,
        ...), or ``invalid_constants`` when the set's forms are nonsense for this design.
    holds : bool
        Whether the requested state exists under the set (``found == requested``).
    predicted_tip : (float, float), mm
        Tip of the state found (NaN when none).
    measured_tip, reference_tip : (float, float) or None, mm
        The measured tip; another model's tip from the file (the paper's own).
    distance, reference_distance : float or None, mm
        ``|predicted − measured|`` and ``|reference − measured|``.
    relative_distance : float or None
        ``distance`` over the measured tip's distance from the base.
    predicted_stiffness : float, N/mm
        Tip stiffness of the state found (MODEL.md §7).
    measured_stiffness : float or None, N/mm
    stiffness_ratio : float or None
        ``predicted_stiffness / measured_stiffness``.
    in_fitted_range : bool
        Whether the design lies in the domain the set was fitted on.
    note : str or None
        What lies outside that domain, or why nothing was solved.
    nodes : ndarray of shape (2N + 2, 2), mm
        The lattice's nodes in the state found (for the figure; not in the JSON form).
    """

    finger: str
    material: str
    constants: str
    fingerprint: str
    requested: str
    found: str
    status: str
    holds: bool
    predicted_tip: tuple[float, float]
    measured_tip: tuple[float, float] | None
    distance: float | None
    relative_distance: float | None
    predicted_stiffness: float
    measured_stiffness: float | None
    stiffness_ratio: float | None
    reference_tip: tuple[float, float] | None
    reference_distance: float | None
    in_fitted_range: bool
    note: str | None
    nodes: NDArray = field(compare=False, repr=False, default_factory=lambda: np.empty((0, 2)))

    @property
    def stiffness_error(self) -> float | None:
        """``stiffness_ratio − 1`` (None without a measured stiffness)."""
        return None if self.stiffness_ratio is None else self.stiffness_ratio - 1.0

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (units: :data:`UNITS`)."""
        return {
            "finger": self.finger,
            "material": self.material,
            "constants": {"name": self.constants, "fingerprint": self.fingerprint},
            "requested": self.requested,
            "found": self.found,
            "status": self.status,
            "holds": self.holds,
            "predicted_tip": _point(self.predicted_tip),
            "measured_tip": _point(self.measured_tip),
            "distance": json_number(self.distance),
            "relative_distance": json_number(self.relative_distance),
            "predicted_stiffness": json_number(self.predicted_stiffness),
            "measured_stiffness": json_number(self.measured_stiffness),
            "stiffness_ratio": json_number(self.stiffness_ratio),
            "stiffness_error": json_number(self.stiffness_error),
            "reference_tip": _point(self.reference_tip),
            "reference_distance": json_number(self.reference_distance),
            "fitted_range": self.in_fitted_range,
            "note": self.note,
        }


@dataclass(frozen=True)
class SetSummary:
    """One constants set on the fingers of one material.

    Attributes
    ----------
    constants, fingerprint, material : str
    fingers, held : int
        Fingers of the material, and how many hold their measured state under the set.
    tips : int
        Fingers with a measured tip; the distances below are over them.
    mean_distance, rms_distance, max_distance : float, mm
        Of the predicted tips to the measured ones (NaN without tips, or when a solve failed).
    mean_relative_distance : float
    reference_mean_distance : float or None, mm
        Mean distance of the file's reference tips (the paper's own model) to the measured ones.
    stiffness_ratios : tuple of float
        ``predicted / measured`` of each finger with a measured stiffness, in file order.
    stiffness_held : tuple of bool
        Whether each of those fingers holds its state (else its ratio is of another state).
    outside_fitted_range : int
        Fingers outside the set's fitted domain.
    """

    constants: str
    fingerprint: str
    material: str
    fingers: int
    held: int
    tips: int
    mean_distance: float
    rms_distance: float
    max_distance: float
    mean_relative_distance: float
    reference_mean_distance: float | None
    stiffness_ratios: tuple[float, ...]
    stiffness_held: tuple[bool, ...]
    outside_fitted_range: int

    @property
    def max_stiffness_error(self) -> float:
        """Largest ``|predicted / measured − 1|`` (NaN without stiffness measurements)."""
        errors = [abs(r - 1.0) for r in self.stiffness_ratios]
        return max(errors) if errors else math.nan

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (units: :data:`UNITS`)."""
        return {
            "constants": {"name": self.constants, "fingerprint": self.fingerprint},
            "material": self.material,
            "fingers": self.fingers,
            "held": self.held,
            "tips": self.tips,
            "mean_distance": json_number(self.mean_distance),
            "rms_distance": json_number(self.rms_distance),
            "max_distance": json_number(self.max_distance),
            "mean_relative_distance": json_number(self.mean_relative_distance),
            "reference_mean_distance": json_number(self.reference_mean_distance),
            "stiffness_ratios": [json_number(r) for r in self.stiffness_ratios],
            "stiffness_held": list(self.stiffness_held),
            "max_stiffness_error": json_number(self.max_stiffness_error),
            "outside_fitted_range": self.outside_fitted_range,
        }


@dataclass(frozen=True)
class Goal:
    """What a constants set must do on printed fingers, against the paper's set.

    Attributes
    ----------
    distance_factor : float
        Its mean tip distance per material at most this many times the paper set's.
    stiffness_tolerance : float
        Every measured stiffness predicted within this fraction (``|ratio − 1|``).

    Every finger must also hold its measured state (a stiffness of another state counts as
    missed).
    """

    distance_factor: float = 1.25
    stiffness_tolerance: float = 0.25

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {
            "distance_factor": self.distance_factor,
            "stiffness_tolerance": self.stiffness_tolerance,
            "states": "every finger holds its measured state",
        }


@dataclass(frozen=True)
class SetVerdict:
    """Whether a constants set meets the :class:`Goal` on a validation's fingers.

    Attributes
    ----------
    constants, fingerprint : str
        The set judged.
    reference, reference_fingerprint : str
        The set its distances are compared with (the paper's).
    passes : bool
    failures : tuple of str
        One phrase per missed part of the goal (empty when it passes).
    summary : str
        One line with the figures: what commands print for a set marked failing.
    limits : dict of str to float, mm
        Per material, the largest mean tip distance the goal allows.
    goal : Goal
    measurements : tuple of (str, str)
        ``(file name, SHA-256)`` of each measurement file judged on.
    """

    constants: str
    fingerprint: str
    reference: str
    reference_fingerprint: str
    passes: bool
    failures: tuple[str, ...]
    summary: str
    limits: dict[str, float] = field(hash=False)
    goal: Goal
    measurements: tuple[tuple[str, str], ...]

    def to_dict(self) -> dict[str, Any]:
        """The JSON form, also what a set's file records (``validation``)."""
        return {
            "format": "dpfexplore-validation/1",
            "set_fingerprint": self.fingerprint,
            "passes": self.passes,
            "summary": self.summary,
            "failures": list(self.failures),
            "reference": {"name": self.reference, "fingerprint": self.reference_fingerprint},
            "limits_mm": {k: json_number(v) for k, v in self.limits.items()},
            "goal": self.goal.to_dict(),
            "measurements": [{"file": n, "sha256": h} for n, h in self.measurements],
        }


@dataclass(frozen=True)
class Validation:
    """The answer of :func:`~.validate.validate`.

    Attributes
    ----------
    fingers : tuple of FingerResult
        Set by set (in the order given), finger by finger (in file order).
    summaries : tuple of SetSummary
        Set by set, material by material (in order of first appearance).
    verdicts : tuple of SetVerdict
        One per set when the paper's set is among them (the goal's reference), else empty.
    sets : tuple of (str, str)
        ``(name, fingerprint)`` of each set.
    measurements : tuple of (str, str, str)
        ``(path, title, SHA-256)`` of each measurement file.
    verified_by : str
        How every predicted value was computed.
    """

    fingers: tuple[FingerResult, ...]
    summaries: tuple[SetSummary, ...]
    verdicts: tuple[SetVerdict, ...]
    sets: tuple[tuple[str, str], ...]
    measurements: tuple[tuple[str, str, str], ...]
    verified_by: str

    def of_set(self, name: str) -> list[FingerResult]:
        """The fingers' results under the set ``name``."""
        return [r for r in self.fingers if r.constants == name]

    def summary(self, name: str, material: str) -> SetSummary:
        """The summary of set ``name`` on ``material`` (KeyError when there is none)."""
        for s in self.summaries:
            if (s.constants, s.material) == (name, material):
                return s
        raise KeyError(f"no summary of set {name!r} on {material!r}")

    def verdict(self, name: str) -> SetVerdict:
        """The verdict on set ``name`` (KeyError when none was made)."""
        for v in self.verdicts:
            if v.constants == name:
                return v
        raise KeyError(f"no verdict on set {name!r} (the paper's set was not validated beside it)")

    def to_dict(self) -> dict[str, Any]:
        """The JSON form of ``dpfexplore validate --json``."""
        return {
            "units": UNITS,
            "verification": self.verified_by,
            "measurements": [{"path": p, "title": t, "sha256": h} for p, t, h in self.measurements],
            "sets": [{"name": n, "fingerprint": f} for n, f in self.sets],
            "fingers": [r.to_dict() for r in self.fingers],
            "summaries": [s.to_dict() for s in self.summaries],
            "verdicts": [v.to_dict() for v in self.verdicts],
        }
