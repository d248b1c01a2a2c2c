"""Designs as TOML files with a ``[design]`` table, as ``dpfexplore states`` reads them.

:func:`design_toml` writes any :class:`~dpfexplore.model.design.Design` (every value at full
precision: ``repr`` of a float reads back to the same float, so a written design reproduces its
outputs exactly), with comments and an optional ``[result]`` table of what was verified; it is
the one writer of the lookup's and the design scenes' result files. :func:`write_designs` saves
the candidates of a lookup, best first, each with comments saying where it comes from and what
it was verified to do.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..model.design import Design
from .query import LookupResult

__all__ = ["design_toml", "toml_value", "write_designs"]


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
) -> str:
    """A TOML document with a ``[design]`` table that :func:`~dpfexplore.load_design` reads.

    ``design`` is a :class:`Design` or its :meth:`~Design.to_dict`; ``comments`` open the file;
    ``result`` (optional) becomes a ``[result]`` table of what was verified (None values left out).
    """
    values = design.to_dict() if isinstance(design, Design) else dict(design)
    lines = [f"# {c}" for c in comments]
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

    ``DIRECTORY`` is a result directory (:mod:`dpfexplore.sweep.result_dirs`): written whole,
    so no candidate file of an earlier lookup survives beside these; one holding an earlier
    result is replaced only with ``force``.
    """
    from ..sweep.result_dirs import result_directory

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
        named = Design(**{**design.to_dict(), "name": f"candidate-{rank:0{width}d}"})
        path.write_text(design_toml(named, comments))
        paths.append(path.name)
    return paths
