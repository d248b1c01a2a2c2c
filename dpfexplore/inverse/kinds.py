"""Scene kinds: one record per kind, in one literal table, and the scene entry points.

A :class:`~.scene_kind.SceneKind` says everything the rest of the package and the ``design``
command need of a kind: the top-level tables its file may have, whether it describes its own
variables, its parser, solver, report, writer and text summary, and how its designs are
verified. Each kind lives in its own package, ``dpfexplore.inverse.scenes.<kind>``, whose
``kind`` module holds the record; nothing registers itself at import. A new kind is one more
package and one more entry of :data:`SCENE_KINDS` (its spec record joins the :data:`KindSpec`
union beside it): the recipe is in the scenes guide (``docs/guide/scenes.md``).

::

    >>> from dpfexplore.inverse.kinds import load_scene
    >>> spec = load_scene("jobs/design-position-cheetah.toml")  # doctest: +SKIP
    >>> type(spec.kind_spec).__name__                            # doctest: +SKIP
    'PositionSpec'
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..io.toml_fields import check_keys, reported_as, table
from ..model.constants_set import DEFAULT, ConstantsSetError, locate_constants_set
from ..model.design import resolve_constants
from .scene_file import SceneSpecError, build_spec, read_scene_file
from .scene_kind import SceneKind
from .scenes.gripper import kind as gripper
from .scenes.gripper.spec import GripperSpec
from .scenes.pickplace import kind as pickplace
from .scenes.pickplace.spec import PickPlaceSpec, with_target_reset
from .scenes.position import kind as position
from .scenes.position.spec import PositionSpec, with_seeds
from .scenes.position_stiffness import kind as position_stiffness
from .scenes.position_stiffness.spec import PositionStiffnessSpec
from .scenes.walker import kind as walker
from .scenes.walker.spec import WalkerSpec
from .spec import SceneSpec

__all__ = [
    "SCENE_KINDS",
    "SCENE_OPTIONS",
    "KindSpec",
    "SceneKind",
    "load_scene",
    "parse_scene",
    "with_constants_file",
]

#: Every scene kind, by its ``scene.kind`` name (each package's ``kind.KIND``: a
#: :class:`~.scene_kind.SceneKind`).
SCENE_KINDS: dict[str, SceneKind] = {
    kind.name: kind
    for kind in (position.KIND, position_stiffness.KIND, gripper.KIND, pickplace.KIND, walker.KIND)
}

#: The spec record of every kind (the type of :attr:`SceneSpec.kind_spec`).
KindSpec = PositionSpec | PositionStiffnessSpec | GripperSpec | PickPlaceSpec | WalkerSpec


@reported_as(SceneSpecError)
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
        check_keys(data, "", required=("scene",), optional=tuple(data))
        check_keys(table(data, "scene"), "scene", required=("kind",), optional=tuple(data["scene"]))
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
    """Read and validate a scene file (:class:`SceneSpecError` naming the key, then the file)."""
    document = read_scene_file(path)
    try:
        return parse_scene(document, default_name=Path(path).stem, base=Path(path).parent)
    except ValueError as exc:  # SceneSpecError, or a design or constants set refused
        if str(path) in str(exc):
            raise
        raise SceneSpecError(f"{exc} (in {path})") from None


def with_constants_file(spec: SceneSpec, path: str | Path) -> SceneSpec:
    """The scene read again under the constants set ``path`` names (``design --constants``).

    Re-read from its document, so that every design the scene makes (reference designs, the
    pick-and-place and walker legs) runs on the set; a scene that names another set is refused.
    """
    try:
        located = locate_constants_set(path)
        given = resolve_constants(path)
    except ConstantsSetError as exc:
        raise SceneSpecError(f"--constants {exc}") from None
    if spec.constants == given:
        return spec
    if spec.constants != DEFAULT:
        raise SceneSpecError(
            f"--constants names constants set {given.label} but the scene names "
            f"{spec.constants.label} (scene.constants); give one"
        )
    document = {**spec.document, "scene": {**spec.document["scene"]}}
    document["scene"]["constants"] = str(Path(located).resolve()) if located else DEFAULT.name
    return parse_scene(document, default_name=spec.name)


#: What the options of ``dpfexplore design`` do to a scene, in the order they apply: each takes
#: the scene and the option's value and refuses, in one line naming the option, a scene it does
#: not apply to (:class:`SceneSpecError` or ``ValueError``).
SCENE_OPTIONS: dict[str, Callable[[SceneSpec, Any], SceneSpec]] = {
    "constants": with_constants_file,
    "target_reset": with_target_reset,
    "seeds": with_seeds,
}
