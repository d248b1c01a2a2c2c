"""A constants set's verdict against printed fingers, recorded in the set's own file.

:func:`record_verdict` validates the set a file holds beside the paper's set on the packaged
measurements (:func:`~.validate.validate`), judges it against the goal (:data:`~.validate.GOAL`)
and writes the verdict into the file as its ``validation`` table (``dpfexplore validate
--record``). Reading the set back (:func:`~dpfexplore.model.constants_set.load_constants_set`)
checks that the verdict names this very set (its ``set_fingerprint``), keeps it as
:attr:`~dpfexplore.model.constants_set.ConstantsSet.validation`, and logs its one-line summary
when the set failed: every command shows that line, and ``dpfexplore design`` refuses the set
unless ``--allow-unvalidated``.

Why the verdict lies outside the fingerprint
    A set's fingerprint is its identity: designs, sweep datasets, lookups and surrogates record
    it and refuse another set. A verdict judges the set, it is not part of it; recording one
    (or recording it again after the measurements grew) must not turn every stored result of
    the set into one "of another set". So the fingerprint is computed without the
    ``validation`` table, and the table carries the fingerprint it judges instead: a verdict
    copied beside other forms, or left behind when the forms change, is refused when read. The
    format version stays ``dpfexplore-constants/1``: files without a verdict load and verify
    exactly as before. (A reader older than this field refuses a file that has one: it counts
    the table into the fingerprint and finds a mismatch.)

The verdict records the measurement files it was judged on by name and SHA-256; the test suite
checks that every packaged set carries a verdict that is current (the one :func:`validate`
gives today).
"""

from __future__ import annotations

import json
from pathlib import Path

from ..io.files import atomic_write
from ..model.constants_set import DEFAULT, ConstantsSet, ConstantsSetError
from ..model.set_checks.fields import read_set_json
from .results import SetVerdict
from .validate import GOAL, MeasurementsLike, validate

__all__ = ["failed_summary", "record_verdict", "verdict_of"]


def verdict_of(constants: ConstantsSet, measurements: MeasurementsLike | None = None) -> SetVerdict:
    """Validate ``constants`` beside the paper's set and judge it (default: packaged fingers)."""
    sets = [DEFAULT] if constants == DEFAULT else [DEFAULT, constants]
    return validate(measurements, sets, goal=GOAL).verdict(constants.name)


def failed_summary(constants: ConstantsSet) -> str | None:
    """The summary line of the verdict recorded with ``constants`` if it failed, else None."""
    verdict = constants.validation
    return None if verdict is None or verdict["passes"] else str(verdict["summary"])


def record_verdict(path: str | Path, measurements: MeasurementsLike | None = None) -> SetVerdict:
    """Judge the set in the file ``path`` and record the verdict there (atomically, read back).

    The file keeps its layout (the one :meth:`ConstantsSet.save` writes) with ``validation``
    added or replaced; its fingerprint does not change. A verdict recorded before is replaced,
    also one that no longer matches the set's forms.

    Raises
    ------
    ConstantsSetError
        A file that is not a readable constants set (one line naming it), or that read back
        does not hold the verdict written.
    """
    path = Path(path)
    data = read_set_json(path)  # bounded, strict JSON; one line naming the file
    if not isinstance(data, dict):
        raise ConstantsSetError(f"{path}: not a constants set (a JSON object)")
    data.pop("validation", None)
    constants = ConstantsSet.from_dict(data, source=str(path))
    verdict = verdict_of(constants, measurements)
    data["validation"] = json.loads(json.dumps(verdict.to_dict(), allow_nan=False))
    atomic_write(path, json.dumps(data, indent=2, sort_keys=True) + "\n")
    back = ConstantsSet.from_dict(read_set_json(path), source=str(path))
    if back.validation != data["validation"] or back != constants:
        raise ConstantsSetError(f"{path}: read back, it does not hold the verdict written")
    return verdict
