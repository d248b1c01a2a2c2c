"""The gripper scene's record in :data:`dpfexplore.inverse.kinds.SCENE_KINDS`."""

from __future__ import annotations

from ...report import RESOLVED_ALONE
from ...scene_kind import SceneKind
from .report import gripper_report, write_gripper_report
from .sorting_stage import solve_scene
from .spec import parse_gripper
from .summary import summary_lines

KIND = SceneKind(
    name="gripper",
    # ``targets`` and ``objective`` are refused by the parser, naming the gripper's own table
    tables=("targets", "objective", "gripper"),
    own_variables=False,
    parse=parse_gripper,
    solve=solve_scene,
    report=gripper_report,
    write=write_gripper_report,
    summary=summary_lines,
    verified=RESOLVED_ALONE,
)
