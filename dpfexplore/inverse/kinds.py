"""Scene kinds: one record per kind, in one literal table, and the scene entry points.

A :class:`SceneKind` says everything the rest of the package needs of a kind: the top-level
tables its file may have, whether it describes its own variables, its parser, how many result
rows it reports, and its solver, report and writer. Nothing registers itself at import: a new
kind is one more line of :data:`SCENE_KINDS`.

::

    >>> from dpfexplore.inverse.kinds import load_scene
    >>> spec = load_scene("jobs/design-position-cheetah.toml")  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..model.constants_set import DEFAULT
from ..model.design import resolve_constants
from .engine.optimiser import TargetResult, solve_position_target
from .evaluation import SceneEvaluator
from .report import gripper_report, position_report, write_report
from .scene_file import build_spec, parse_gripper, parse_position, read_scene_file
from .scenes.gripper.solve import solve_gripper
from .scenes.pickplace.report import pickplace_report, write_timing_report
from .scenes.pickplace.solve import solve_pickplace
from .scenes.pickplace.spec import parse_pickplace
from .scenes.walker.report import walker_report, write_walker_report
from .scenes.walker.solve import solve_walker
from .scenes.walker.spec import parse_walker
from .spec import SceneSpec
from .spec_fields import SceneSpecError, _keys, _table

__all__ = ["SCENE_KINDS", "SceneKind", "load_scene", "parse_scene"]


@dataclass(frozen=True)
class SceneKind:
    """One kind of scene.

    Attributes
    ----------
    name : str
        The ``scene.kind`` value.
    tables : tuple of str
        Top-level tables the file may have besides ``scene``, ``variables``, ``optimiser``.
    own_variables : bool
        The kind describes its variables itself (no ``[variables]`` table).
    parse : callable
        ``parse(data, fields) -> dict``: the kind's own fields of the :class:`SceneSpec`.
    n_results : callable
        ``n_results(spec) -> int``: result rows (one per target; the gripper has one).
    solve : callable
        ``solve(spec, index, evaluator) -> TargetResult`` for result row ``index``.
    report : callable
        ``report(spec, result, evaluator) -> dict``: the verified row.
    write : callable
        ``write(spec, rows, evaluator, directory, *, wall_s, plot)``: the report's files.
    """

    name: str
    tables: tuple[str, ...]
    own_variables: bool
    parse: Callable[[Mapping[str, Any], dict[str, Any]], dict[str, Any]]
    n_results: Callable[[SceneSpec], int]
    solve: Callable[[SceneSpec, int, SceneEvaluator], TargetResult]
    report: Callable[[SceneSpec, TargetResult, SceneEvaluator], dict[str, Any]]
    write: Callable[..., list[Path]]


def _per_target(spec: SceneSpec) -> int:
    return len(spec.targets)


def _solve_front(spec: SceneSpec, index: int, evaluator: SceneEvaluator) -> TargetResult:
    return solve_position_target(spec, index, evaluator, exhaustive=True)


_POSITION_TABLES = ("targets", "objective", "gripper")

#: Every scene kind (see :class:`SceneKind`).
SCENE_KINDS: dict[str, SceneKind] = {
    kind.name: kind
    for kind in (
        SceneKind(
            "position",
            _POSITION_TABLES,
            False,
            parse_position,
            _per_target,
            solve_position_target,
            position_report,
            write_report,
        ),
        SceneKind(
            "position_stiffness",
            _POSITION_TABLES,
            False,
            parse_position,
            _per_target,
            _solve_front,
            position_report,
            write_report,
        ),
        SceneKind(
            "gripper",
            _POSITION_TABLES,
            False,
            parse_gripper,
            lambda spec: 1,  # one result: the set of apertures
            solve_gripper,
            gripper_report,
            write_report,
        ),
        SceneKind(
            "pickplace",
            ("pickplace",),
            False,
            parse_pickplace,
            lambda spec: spec.pickplace.n_results,
            solve_pickplace,
            pickplace_report,
            write_timing_report,
        ),
        SceneKind(
            "walker_leg",
            ("walker",),
            True,
            parse_walker,
            lambda spec: spec.walker.n_results,
            solve_walker,
            walker_report,
            write_walker_report,
        ),
    )
}


def parse_scene(
    data: Mapping[str, Any], *, default_name: str = "scene", base: str | Path | None = None
) -> SceneSpec:
    """Validate a TOML-shaped mapping into a :class:`SceneSpec` (one-line errors naming keys).

    ``base`` is the folder relative paths in the scene (``scene.constants``) start from.
    """
    if "scene" not in data and ("job" in data or "space" in data):
        raise SceneSpecError(
            "this is a sweep job ([job], [space]), not a design scene ([scene]): run it with "
            "dpfexplore sweep; design scenes are in jobs/design-*.toml"
        )
    if not isinstance(data.get("scene"), Mapping) or "kind" not in data["scene"]:
        _keys(data, "", required=("scene",), optional=tuple(data))
        _keys(_table(data, "scene"), "scene", required=("kind",), optional=tuple(data["scene"]))
    name = data["scene"]["kind"]
    if not isinstance(name, str) or name not in SCENE_KINDS:
        known = ", ".join(SCENE_KINDS)
        raise SceneSpecError(f"scene.kind = {name!r}: unknown kind; known: {known}")
    kind = SCENE_KINDS[name]
    return build_spec(
        data,
        kind=name,
        tables=kind.tables,
        own_variables=kind.own_variables,
        parse=kind.parse,
        default_name=default_name,
        base=base,
    )


def load_scene(path: str | Path) -> SceneSpec:
    """Read and validate a scene file (:class:`SceneSpecError` naming the key)."""
    return parse_scene(read_scene_file(path), default_name=Path(path).stem, base=Path(path).parent)


def with_constants_file(spec: SceneSpec, path: str | Path) -> SceneSpec:
    """The scene read again under the constants set file ``path`` (``design --constants``).

    Re-read from its document, so that every design the scene makes (reference designs, the
    pick-and-place and walker legs) runs on the set; a scene that names another set is refused.
    """
    given = resolve_constants(path)
    if spec.constants == given:
        return spec
    if spec.constants != DEFAULT:
        raise SceneSpecError(
            f"--constants names constants set {given.label} but the scene names "
            f"{spec.constants.label} (scene.constants); give one"
        )
    document = {**spec.document, "scene": {**spec.document["scene"]}}
    document["scene"]["constants"] = str(Path(path).resolve())
    return parse_scene(document, default_name=spec.name)
