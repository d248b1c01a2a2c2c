"""What a kind of scene is: the :class:`SceneKind` record and what its results offer.

Each kind lives in its own package, ``dpfexplore.inverse.scenes.<kind>``, whose ``kind`` module
holds its :class:`SceneKind` (``KIND``); the literal table
:data:`dpfexplore.inverse.kinds.SCENE_KINDS` lists them. Nothing registers itself at import.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from .evaluation import SceneEvaluator
from .spec import SceneCommon, SceneSpec

__all__ = ["SceneKind", "SceneResult"]


class SceneResult(Protocol):
    """What every kind's result record offers (one per result row of a scene)."""

    #: The row's target (or targets) was met by a verified design.
    reachable: bool

    @property
    def met(self) -> bool:
        """The target was met and every check of the kind passed (else exit code 1)."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` row: what ``summary.json`` holds for this result."""
        ...


@dataclass(frozen=True)
class SceneKind:
    """One kind of scene: everything the package and the ``design`` command need of it.

    Attributes
    ----------
    name : str
        The ``scene.kind`` value.
    tables : tuple of str
        Top-level tables the file may have besides ``scene``, ``variables``, ``optimiser``.
    own_variables : bool
        The kind describes its variables itself (no ``[variables]`` table); its kind spec's
        ``n_units`` are the scene's.
    parse : callable
        ``parse(data, common) -> kind spec``: the kind's own tables, given the
        :class:`~.spec.SceneCommon` parts already read. The kind spec's ``n_results`` is the
        number of result rows.
    solve : callable
        ``solve(spec, index, evaluator) -> outcome`` for result row ``index`` (the kind's own
        record, handed to ``report``).
    report : callable
        ``report(spec, outcome, evaluator) -> result``: the verified result
        (:class:`SceneResult`).
    write : callable
        ``write(spec, results, evaluator, directory, *, wall_s, plot) -> paths``: the report's
        files.
    summary : callable
        ``summary(spec, rows) -> lines``: the text summary of the ``--json`` rows.
    verified : str
        How every reported design was verified (the summary's last line says it).
    """

    name: str
    tables: tuple[str, ...]
    own_variables: bool
    parse: Callable[[Mapping[str, Any], SceneCommon], Any]
    solve: Callable[[SceneSpec, int, SceneEvaluator], Any]
    report: Callable[[SceneSpec, Any, SceneEvaluator], SceneResult]
    write: Callable[..., list[Path]]
    summary: Callable[[SceneSpec, Sequence[Mapping[str, Any]]], list[str]]
    verified: str
