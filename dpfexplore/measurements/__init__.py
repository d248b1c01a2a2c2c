"""Measurements of printed fingers, and how well the model predicts them.

The ground truth of the project (MODEL.md §13): fingers printed and measured, as data files a lab
writes for its own prints (the format: :mod:`.fingers`); the paper's ship with the package.
:func:`validate` solves each finger under each constants set and compares; a set's verdict can
be recorded in its file (:mod:`.verdict`), and commands announce a set that failed.

Modules
-------
fingers
    The measurement file format, :class:`Measurement`, :func:`read_measurements`.
writer
    :func:`write_measurements`: records back to the file format (read back before success).
validate
    :func:`validate`, the goal a set must meet, :func:`judge`.
results
    The records :func:`validate` returns (per finger, per set and material, verdicts).
verdict
    A set's verdict recorded in its file, and read back checked.
report
    The text table, the one-line summary and the Markdown report of a validation.

Pipeline: after :mod:`dpfexplore.solvers` and :mod:`dpfexplore.plotting`, before the CLI.
"""

from .fingers import (
    FORMAT,
    Measurement,
    MeasurementError,
    MeasurementFile,
    packaged_measurements,
    read_measurements,
)
from .results import FingerResult, Goal, SetSummary, SetVerdict, Validation
from .validate import GOAL, default_sets, judge, validate
from .writer import measurements_toml, write_measurements

__all__ = [
    "FORMAT",
    "GOAL",
    "FingerResult",
    "Goal",
    "Measurement",
    "MeasurementError",
    "MeasurementFile",
    "SetSummary",
    "SetVerdict",
    "Validation",
    "default_sets",
    "judge",
    "measurements_toml",
    "packaged_measurements",
    "read_measurements",
    "validate",
    "write_measurements",
]
