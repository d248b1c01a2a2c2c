"""The walker-leg scene's record in :data:`dpfexplore.inverse.kinds.SCENE_KINDS`."""

from __future__ import annotations

from ...report import SIMULATED_ALONE
from ...scene_kind import SceneKind
from .report import walker_report, write_walker_report
from .solve import solve_walker
from .spec import parse_walker
from .summary import summary_lines

KIND = SceneKind(
    name="walker_leg",
    tables=("walker",),
    own_variables=True,  # one set of variables per section, in [walker.variables]
    parse=parse_walker,
    solve=solve_walker,
    report=walker_report,
    write=write_walker_report,
    summary=summary_lines,
    verified=SIMULATED_ALONE,
)
