"""The pick-and-place scene's record in :data:`dpfexplore.inverse.kinds.SCENE_KINDS`."""

from __future__ import annotations

from ...report import SIMULATED_ALONE
from ...scene_kind import SceneKind
from .report import pickplace_report, write_pickplace_report
from .solve import solve_pickplace
from .spec import parse_pickplace
from .summary import summary_lines

KIND = SceneKind(
    name="pickplace",
    tables=("pickplace",),
    own_variables=False,
    parse=parse_pickplace,
    solve=solve_pickplace,
    report=pickplace_report,
    write=write_pickplace_report,
    summary=summary_lines,
    verified=SIMULATED_ALONE,
)
