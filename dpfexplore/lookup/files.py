"""Designs as TOML files with a ``[design]`` table, as ``dpfexplore states`` reads them.

:func:`design_toml` writes any :class:`~dpfexplore.model.design.Design` (every value at full
precision: ``repr`` of a float reads back to the same float, so a written design reproduces its
outputs exactly), with comments and an optional ``[result]`` table of what was verified; it is
the one writer of the lookup's and the design scenes' result files. :func:`write_designs` saves
the candidates of a lookup, best first, each with comments saying where it comes from and what
it was verified to do.

A design of a constants set other than the paper's is written with ``constants =
"constants.json"``, and the writer of the result directory puts the set there
(:func:`write_constants_beside`): the files read back under the set they were verified with.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.design import Design
from .query import LookupResult

__all__ = ["CONSTANTS_FILE", "design_toml", "toml_value", "write_constants_beside", "write_designs"]

#: Name of the constants set file a result directory holds beside designs of a non-paper set.
CONSTANTS_FILE = "constants.json"


def write_constants_beside(constants: ConstantsSet, directory: str | Path) -> list[Path]:
    """Save ``constants`` as ``DIRECTORY/constants.json`` unless it is the paper's set.

    Returns the written path (or nothing).
    """
    if constants == DEFAULT:
        return []
    return [constants.save(Path(directory) / CONSTANTS_FILE)]


def toml_value(value: Any) -> str:
    """A TOML literal: floats at full precision (``repr`` reads back exactly).

    ``None`` inside a list is written as the string ``"none"`` (TOML has no null).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join('"none"' if v is None else toml_value(v) for v in value) + "]"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    raise TypeError(f"{type(value).__name__} has no TOML form here")


def design_toml(
    design: Design | Mapping[str, Any],
    comments: Sequence[str] = (),
    result: Mapping[str, Any] | None = None,
    constants: ConstantsSet | None = None,
) -> str:
    """A TOML document with a ``[design]`` table that :func:`~dpfexplore.load_design` reads.

    ``design`` is a :class:`Design` or its :meth:`~Design.to_dict`; ``comments`` open the file;
    ``result`` (optional) becomes a ``[result]`` table of what was verified (None values left out).
    The design's constants set (a Design's own, else ``constants``) other than the paper's is
    named as ``constants = "constants.json"``: the writer saves it beside the file.
    """
    values = design.to_dict() if isinstance(design, Design) else dict(design)
    lines = [f"# {c}" for c in comments]
    if isinstance(design, Design):
        constants = design.constants
    if constants is not None and constants != DEFAULT:
        lines.append(f"# under constants set {constants.label}, saved beside this file")
        values["constants"] = CONSTANTS_FILE
    lines.append("[design]")
    lines += [f"{key} = {toml_value(value)}" for key, value in values.items()]
    if result:
        lines += ["", "[result]"]
        lines += [
            f"{key} = {toml_value(value)}" for key, value in result.items() if value is not None
        ]
    return "\n".join(lines) + "\n"


def write_designs(
    result: LookupResult, directory: str | Path, *, force: bool = False
) -> list[Path]:
    """Save each candidate as ``DIRECTORY/candidate-01.toml`` ... (best first).

    ``DIRECTORY`` is a result directory (:mod:`dpfexplore.io.result_dirs`): written
    whole, so no candidate file of an earlier lookup survives beside these; one holding an earlier
    result is replaced only with ``force``.
    """
    from ..io.result_dirs import result_directory

    final = Path(directory)
    with result_directory(final, kind="lookup-designs", force=force, option="--write") as staging:
        names = _write_candidates(result, staging)
    return [final / name for name in names]


def _write_candidates(result: LookupResult, directory: Path) -> list[str]:
    paths = []
    width = max(2, len(str(len(result.candidates))))
    for rank, c in enumerate(result.candidates, start=1):
        path = directory / f"candidate-{rank:0{width}d}.toml"
        target = ", ".join(
            f"{col} = {v:g}" for col, v in zip(result.columns, result.target, strict=True)
        )
        comments = [
            f"dpfexplore lookup {result.dataset.root}: candidate {rank} for {target}",
            f"state {c.state}: tip = ({c.tip[0]:.9f}, {c.tip[1]:.9f}) mm, error {c.error:.3g}, "
            f"status {c.status} (re-solved by the exact model)",
            f"from design_id {c.design_id} of the dataset" + (", refined" if c.refined else ""),
        ]
        if c.fitted_range_note:
            comments.append(c.fitted_range_note)
        design = c.design
        named = design.replace(name=f"candidate-{rank:0{width}d}")
        path.write_text(design_toml(named, comments))
        paths.append(path.name)
    sets = {c.design.constants for c in result.candidates}
    written = [p for constants in sets for p in write_constants_beside(constants, directory)]
    return paths + [p.name for p in written]
