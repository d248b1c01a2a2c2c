"""The position-and-stiffness scene's record in :data:`dpfexplore.inverse.kinds.SCENE_KINDS`.

Its results are the position scene's records (with their fronts and weighted sums), reported,
written and summarised by the position package.
"""

from __future__ import annotations

from ...report import RESOLVED_ALONE
from ...scene_kind import SceneKind
from ..position.kind import TABLES
from ..position.report import position_report, write_position_report
from ..position.summary import summary_lines
from .solve import solve_position_stiffness
from .spec import parse_position_stiffness

KIND = SceneKind(
    name="position_stiffness",
    tables=TABLES,
    own_variables=False,
    parse=parse_position_stiffness,
    solve=solve_position_stiffness,
    report=position_report,
    write=write_position_report,
    summary=summary_lines,
    verified=RESOLVED_ALONE,
)
