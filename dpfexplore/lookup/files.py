"""Designs as TOML files with a ``[design]`` table, as ``dpfexplore states`` reads them.

:func:`write_design_file` writes any :class:`~dpfexplore.model.design.Design` (every value at
full precision: ``repr`` of a float reads back to the same float, so a written design reproduces
its outputs exactly), with comments and an optional ``[result]`` table of what was verified, by
a TOML writer, and reads the file back before it returns
(:func:`~dpfexplore.io.toml_write.write_toml`); it is the one writer of the lookup's and the
design scenes' result files. :func:`write_designs` saves
the candidates of a lookup, best first, each with comments saying where it comes from and what
it was verified to do.

A design of a constants set other than the paper's is written with ``constants =
"constants.json"``, and the writer of the result directory puts the set there
(:func:`write_constants_beside`): the files read back under the set they were verified with.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..io.toml_write import toml_document, write_toml
from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.design import Design
from .query import LookupResult

__all__ = [
    "CONSTANTS_FILE",
    "design_document",
    "design_toml",
    "write_constants_beside",
    "write_design_file",
    "write_designs",
]

#: Name of the constants set file a result directory holds beside designs of a non-paper set.
CONSTANTS_FILE = "constants.json"


def write_constants_beside(constants: ConstantsSet, directory: str | Path) -> list[Path]:
    """Save ``constants`` as ``DIRECTORY/constants.json`` unless it is the paper's set.

    Returns the written path (or nothing).
    """
    if constants == DEFAULT:
        return []
    return [constants.save(Path(directory) / CONSTANTS_FILE)]


def design_document(
    design: Design | Mapping[str, Any],
    comments: Sequence[str] = (),
    result: Mapping[str, Any] | None = None,
    constants: ConstantsSet | None = None,
) -> tuple[dict[str, Any], list[str]]:
    """The document of a design file and its opening comments (see :func:`design_toml`)."""
    values = design.to_dict() if isinstance(design, Design) else dict(design)
    lines = list(comments)
    if isinstance(design, Design):
        constants = design.constants
    if constants is not None and constants != DEFAULT:
        lines.append(f"under constants set {constants.label}, saved beside this file")
        values["constants"] = CONSTANTS_FILE
    document: dict[str, Any] = {"design": values}
    if result:
        document["result"] = {key: value for key, value in result.items() if value is not None}
    return document, lines


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
    return toml_document(*design_document(design, comments, result, constants))


def write_design_file(
    path: str | Path,
    design: Design | Mapping[str, Any],
    comments: Sequence[str] = (),
    result: Mapping[str, Any] | None = None,
    constants: ConstantsSet | None = None,
) -> Path:
    """Write :func:`design_toml`'s document to ``path`` and read it back (the path).

    Raises
    ------
    dpfexplore.io.toml_write.TomlWriteError
        If the file does not read back as written (one line naming it).
    """
    document, lines = design_document(design, comments, result, constants)
    return write_toml(path, document, lines, kind="design")


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
        write_design_file(path, named, comments)
        paths.append(path.name)
    sets = {c.design.constants for c in result.candidates}
    written = [p for constants in sets for p in write_constants_beside(constants, directory)]
    return paths + [p.name for p in written]
