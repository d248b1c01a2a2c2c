"""How well a constants set predicts printed fingers: :func:`validate`.

Each measured finger is solved under each constants set by the project's state search,
:func:`~dpfexplore.solvers.statics.find_state`, on the finger alone (the exact lattice model,
default solver options; nothing cached, interpolated or learned): the measured state is
requested, and the state found, its tip and its tip stiffness are compared with the
measurement. A finger whose requested state does not exist under a set does not *hold* it; its
tip and stiffness are then those of the state it collapses to, and count as such.

Per set and material the tip distances are summarised (mean, RMS, max; also relative to the
measured tip's distance from the base), with the fingers held and the stiffness ratios; a design
outside the domain a set was fitted on is flagged, as everywhere in the project
(:attr:`~dpfexplore.model.design.Design.fitted_range_note`). When the paper's set is among those
validated, each set is judged against the :class:`~.results.Goal` relative to it
(:class:`~.results.SetVerdict`): every finger holds its state, the mean tip distance per
material is at most 1.25x the paper set's, every measured stiffness is within 25 %.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..model.constants_set import DEFAULT, ConstantsSet, find_constants_set, packaged_sets
from ..solvers.statics import find_state
from .fingers import Measurement, MeasurementFile, packaged_measurements, read_measurements
from .results import FingerResult, Goal, SetSummary, SetVerdict, Validation

__all__ = ["GOAL", "VERIFIED_BY", "default_sets", "judge", "validate"]

#: The goal a set must meet: every state held, 1.25x the paper set's mean tip distance, stiffness
#: within 25 % (docs/guide/validation.md).
GOAL = Goal()
#: How every predicted value is computed (said in every output).
VERIFIED_BY = (
    "every predicted value is find_state's on the finger alone (exact model, default solver "
    "options), under each set"
)

MeasurementsLike = str | Path | MeasurementFile | Sequence[str | Path | MeasurementFile]
ConstantsLike = ConstantsSet | str | Path | Sequence[ConstantsSet | str | Path]


def default_sets() -> list[ConstantsSet]:
    """The paper's set and every packaged set: what ``dpfexplore validate`` runs by default."""
    return [DEFAULT, *(find_constants_set(name) for name in packaged_sets())]


def _files(measurements: MeasurementsLike | Sequence[Measurement] | None) -> list[MeasurementFile]:
    if measurements is None:
        return [read_measurements(p) for p in packaged_measurements()]
    if isinstance(measurements, str | Path | MeasurementFile):
        measurements = [measurements]
    items = list(measurements)
    if items and all(isinstance(m, Measurement) for m in items):
        from .writer import measurements_toml

        digest = hashlib.sha256(measurements_toml(items).encode()).hexdigest()
        return [MeasurementFile(path="", fingers=tuple(items), sha256=digest)]
    files = []
    for item in items:
        if isinstance(item, Measurement):
            raise TypeError("measurements: give fingers (Measurement) or files, not both")
        files.append(item if isinstance(item, MeasurementFile) else read_measurements(item))
    if not files:
        raise ValueError("measurements: need at least one measurement file or finger")
    return files


def _sets(constants: ConstantsLike | None) -> list[ConstantsSet]:
    if constants is None:
        return default_sets()
    if isinstance(constants, ConstantsSet | str | Path):
        constants = [constants]
    sets = [c if isinstance(c, ConstantsSet) else find_constants_set(c) for c in constants]
    if not sets:
        raise ValueError("constants: need at least one constants set")
    names = [s.name for s in sets]
    for name in names:
        if names.count(name) > 1:
            raise ValueError(f"constants: two sets are named {name!r}; give each set once")
    return sets


def _distance(a: tuple[float, float] | None, b: tuple[float, float] | None) -> float | None:
    return None if a is None or b is None else math.hypot(a[0] - b[0], a[1] - b[1])


def _solve(m: Measurement, constants: ConstantsSet) -> FingerResult:
    """One finger under one set, by find_state."""
    common = {
        "finger": m.name,
        "material": m.material_label,
        "constants": constants.name,
        "fingerprint": constants.fingerprint,
        "requested": m.state,
        "measured_tip": m.tip,
        "measured_stiffness": m.stiffness,
        "reference_tip": m.reference_tip,
        "reference_distance": _distance(m.reference_tip, m.tip),
    }
    try:
        design = (
            m.design if m.design.constants == constants else m.design.replace(constants=constants)
        )
    except ValueError as exc:  # the set's forms are nonsense for this geometry: nothing to solve
        return FingerResult(
            **common,
            found="",
            status="invalid_constants",
            holds=False,
            predicted_tip=(math.nan, math.nan),
            distance=math.nan if m.tip else None,
            relative_distance=math.nan if m.tip else None,
            predicted_stiffness=math.nan,
            stiffness_ratio=math.nan if m.stiffness else None,
            in_fitted_range=False,
            note=str(exc),
        )
    result = find_state(design, m.state)
    tip = (float(result.tip[0]), float(result.tip[1]))
    distance = _distance(tip, m.tip)
    stiffness = float(result.stiffness)
    note = design.fitted_range_note
    return FingerResult(
        **common,
        found=result.found,
        status=result.status.label,
        holds=result.stable,
        predicted_tip=tip,
        distance=distance,
        relative_distance=None if distance is None else distance / m.base_distance,
        predicted_stiffness=stiffness,
        stiffness_ratio=None if m.stiffness is None else stiffness / m.stiffness,
        in_fitted_range=note is None,
        note=note,
        nodes=result.nodes,
    )


def _summaries(results: Sequence[FingerResult]) -> list[SetSummary]:
    out = []
    groups: dict[tuple[str, str], list[FingerResult]] = {}
    for r in results:
        groups.setdefault((r.constants, r.material), []).append(r)
    for (name, material), rows in groups.items():
        d = np.array([r.distance for r in rows if r.distance is not None], dtype=float)
        rel = np.array([r.relative_distance for r in rows if r.distance is not None], dtype=float)
        ref = [r.reference_distance for r in rows if r.reference_distance is not None]
        stiff = [r for r in rows if r.stiffness_ratio is not None]
        empty = d.size == 0
        out.append(
            SetSummary(
                constants=name,
                fingerprint=rows[0].fingerprint,
                material=material,
                fingers=len(rows),
                held=sum(r.holds for r in rows),
                tips=int(d.size),
                mean_distance=math.nan if empty else float(np.mean(d)),
                rms_distance=math.nan if empty else float(np.sqrt(np.mean(d * d))),
                max_distance=math.nan if empty else float(np.max(d)),
                mean_relative_distance=math.nan if empty else float(np.mean(rel)),
                reference_mean_distance=float(np.mean(ref)) if ref else None,
                stiffness_ratios=tuple(float(r.stiffness_ratio) for r in stiff),
                stiffness_held=tuple(r.holds for r in stiff),
                outside_fitted_range=sum(not r.in_fitted_range for r in rows),
            )
        )
    return out


def judge(
    validation: Validation,
    name: str,
    *,
    reference: ConstantsSet = DEFAULT,
    goal: Goal = GOAL,
) -> SetVerdict:
    """The verdict on set ``name`` against ``goal``, relative to the ``reference`` set.

    Parameters
    ----------
    validation : Validation
        Results that hold both sets on the same fingers (its verdicts are not read).
    name : str
        The set judged.
    reference : ConstantsSet
        The set whose mean tip distances the goal scales (the paper's).
    goal : Goal

    Raises
    ------
    KeyError
        When ``validation`` lacks the results of either set.
    """
    results, summaries = validation.fingers, validation.summaries
    record = tuple((Path(p).name or "(given in Python)", h) for p, _, h in validation.measurements)
    n_fingers = len({r.finger for r in results})
    title = f"{n_fingers} printed fingers of {', '.join(file for file, _ in record)}"
    mine = [s for s in summaries if s.constants == name]
    refs = {s.material: s for s in summaries if s.fingerprint == reference.fingerprint}
    if not mine or not refs:
        raise KeyError(f"judge: need the results of both {name!r} and {reference.name!r}")
    failures: list[str] = []
    limits: dict[str, float] = {}
    held, distances = [], []
    for s in mine:
        held.append(f"{s.held}/{s.fingers} {s.material}")
        if s.held < s.fingers:
            failures.append(f"holds the measured state of {s.held} of {s.fingers} {s.material}")
        if s.tips:
            limit = goal.distance_factor * refs[s.material].mean_distance
            limits[s.material] = limit
            distances.append(f"{s.mean_distance:.2f} mm {s.material} (<= {limit:.2f})")
            if not s.mean_distance <= limit:  # NaN (a failed solve) fails too
                failures.append(
                    f"mean tip distance {s.mean_distance:.2f} mm on {s.material}, above "
                    f"{limit:.2f} ({goal.distance_factor:g}x the {reference.name} set's)"
                )
    stiff = [r for r in results if r.constants == name and r.stiffness_ratio is not None]
    errors = []
    for r in stiff:
        error = r.stiffness_ratio - 1.0
        errors.append(f"{error:+.0%}" + ("" if r.holds else "*"))
        if not (r.holds and abs(error) <= goal.stiffness_tolerance):
            why = f"{error:+.0%}" if r.holds else f"{error:+.0%}, of the state {r.found or '-'}"
            failures.append(f"tip stiffness of {r.finger} {r.predicted_stiffness:.3f} N/mm ({why})")
    me = mine[0]
    label = f"{name!r} ({me.fingerprint[:12]})"
    parts = [f"held {', '.join(held)}"]
    if distances:
        parts.append(f"mean tip distance {', '.join(distances)}")
    if errors:
        note = "; *: state not held" if any(not r.holds for r in stiff) else ""
        parts.append(
            f"tip stiffness {', '.join(errors)} of measured "
            f"(within {goal.stiffness_tolerance:.0%}{note})"
        )
    verb = "passes" if not failures else "FAILS"
    summary = f"constants set {label} {verb} validation against {title}: " + "; ".join(parts)
    return SetVerdict(
        constants=name,
        fingerprint=me.fingerprint,
        reference=reference.name,
        reference_fingerprint=reference.fingerprint,
        passes=not failures,
        failures=tuple(failures),
        summary=summary,
        limits=limits,
        goal=goal,
        measurements=record,
    )


def validate(
    measurements: MeasurementsLike | Sequence[Measurement] | None = None,
    constants: ConstantsLike | None = None,
    *,
    goal: Goal = GOAL,
) -> Validation:
    """Predict printed fingers under constants sets and compare with what was measured.

    Parameters
    ----------
    measurements : path, MeasurementFile, sequence of them, or sequence of Measurement, optional
        Measurement files (format: :mod:`dpfexplore.measurements.fingers`); default: the
        packaged ones (the paper's printed fingers).
    constants : ConstantsSet, name, path, or sequence of them, optional
        The sets to validate (``"paper"``, a packaged set's name, a file); default: the paper's
        set and every packaged set.
    goal : Goal
        What the verdicts ask of a set, relative to the paper's.

    Returns
    -------
    Validation
        Per finger and set, per set and material, and a verdict per set when the paper's set is
        among them.

    Raises
    ------
    MeasurementError
        A measurement file that cannot be used (one line naming file, finger and key).
    ConstantsSetError
        A set that cannot be found or read.
    """
    files = _files(measurements)
    sets = _sets(constants)
    fingers = [m for f in files for m in f.fingers]
    results = [_solve(m, s) for s in sets for m in fingers]
    validation = Validation(
        fingers=tuple(results),
        summaries=tuple(_summaries(results)),
        verdicts=(),
        sets=tuple((s.name, s.fingerprint) for s in sets),
        measurements=tuple((f.path, f.title, f.sha256) for f in files),
        verified_by=VERIFIED_BY,
    )
    if not any(s == DEFAULT for s in sets):  # the goal is relative to the paper's set
        return validation
    verdicts = tuple(judge(validation, s.name, goal=goal) for s in sets)
    return dataclasses.replace(validation, verdicts=verdicts)
