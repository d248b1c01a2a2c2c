"""The position scene's record in :data:`dpfexplore.inverse.kinds.SCENE_KINDS`."""

from __future__ import annotations

from ...report import RESOLVED_ALONE
from ...scene_kind import SceneKind
from .report import position_report, write_position_report
from .solve import solve_position_target
from .spec import parse_position
from .summary import summary_lines

#: The file's own tables (``gripper`` is refused by the parser, naming the kind).
TABLES = ("targets", "objective", "gripper")

KIND = SceneKind(
    name="position",
    tables=TABLES,
    own_variables=False,
    parse=parse_position,
    solve=solve_position_target,
    report=position_report,
    write=write_position_report,
    summary=summary_lines,
    verified=RESOLVED_ALONE,
)
