"""Designs as TOML files with a ``[design]`` table, as ``dpfexplore states`` reads them.

:func:`design_toml` writes any :class:`~dpfexplore.model.design.Design` (every value at full
precision: ``repr`` of a float reads back to the same float, so a written design reproduces its
outputs exactly); :func:`write_designs` saves the candidates of a lookup, best first, each with
comments saying where it comes from and what it was verified to do.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..model.design import Design
from .lookup import LookupResult

__all__ = ["design_toml", "write_designs"]


def design_toml(design: Design, comments: Sequence[str] = ()) -> str:
    """A TOML document with a ``[design]`` table that :func:`~dpfexplore.load_design` reads."""

    def number(v: float) -> str:
        return repr(float(v))

    lines = [f"# {c}" for c in comments]
    lines.append("[design]")
    if design.name:
        lines.append(f'name = "{design.name}"')
    for name in ("H", "U_L", "U_sep"):
        values = getattr(design, name)
        lines.append(f"{name} = [{', '.join(number(v) for v in values)}]")
    for name in ("t", "t_lim", "E", "nu", "r_b", "t_ch"):
        lines.append(f"{name} = {number(getattr(design, name))}")
    return "\n".join(lines) + "\n"


def write_designs(result: LookupResult, directory: str | Path) -> list[Path]:
    """Save each candidate as ``DIRECTORY/candidate-01.toml`` ... (best first)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    width = max(2, len(str(len(result.candidates))))
    for rank, c in enumerate(result.candidates, start=1):
        path = directory / f"candidate-{rank:0{width}d}.toml"
        target = ", ".join(f"{col} = {v:g}" for col, v in zip(result.columns, result.target,
                                                              strict=True))  # fmt: skip
        comments = [
            f"dpfexplore lookup {result.dataset.root}: candidate {rank} for {target}",
            f"state {c.state}: tip = ({c.tip[0]:.9f}, {c.tip[1]:.9f}) mm, error {c.error:.3g}, "
            f"status {c.status} (re-solved by the exact model)",
            f"from design_id {c.design_id} of the dataset"
            + (", refined" if c.refined else ""),
        ]
        if c.fitted_range_note:
            comments.append(c.fitted_range_note)
        design = c.design
        named = Design(**{**design.to_dict(), "name": f"candidate-{rank:0{width}d}"})
        path.write_text(design_toml(named, comments))
        paths.append(path)
    return paths
