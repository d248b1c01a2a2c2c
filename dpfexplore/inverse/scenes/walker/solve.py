"""The walker-leg scene (MODEL.md §10; the paper's Dome Phalanx Walker): zones that keep time.

A leg is three sections (:mod:`dpfexplore.solvers.legs.leg`): the purple zone (two units, phase 1),
the green zone (one unit, phase 2) and the action section (the action unit, then bistable units
that stay flat while walking; phase 2). The scene is a gait and what each zone must do
(:class:`~dpfexplore.inverse.scenes.walker.spec.WalkerRequirements`); the variables are each
section's heights and thickness. Each requirement involves one section under one phase, so each
section is designed alone, simulated only under the phase that moves it; the leg is composed only to
measure the stride (the extent of the tip path) and draw the gait.

Method
------
Reset times diverge at each unit's bistable edge, and the timing requirements sit close to it;
the map is smooth along a height but finite differences of the full model are noisy there, so
heights are found by roots (Brent's method,
:func:`~dpfexplore.inverse.engine.roots.root_on_line`) rather than a gradient step. Every
full-model run here follows the whole horizon (no early stop: a unit may re-invert when its
neighbour snaps back, and only the last crossing is its reset).

* **Purple zone** (both units metastable, each reset time in the window ``purple_reset``; both
  invert below the walking pressure by the margin). Per value of ``t`` (``t_lines`` of them):
  the heights ``(H_1, H_2)`` that put the two reset times on their aims ``purple_aim``, by
  nested roots (for each ``H_1``, ``H_2`` by Brent; then ``H_1`` by Brent), brackets grown from
  each unit's edge on a batch scan of equal heights. The solutions are re-simulated at the
  verification tolerance, their inversion pressures computed (:mod:`.inversion`, one batch) and
  the leg's stride at the walking gait decides between those that meet every requirement.
* **Green zone** (its class, inverting below the walking pressure): a batch scan of heights per
  ``t``; the tallest that meets both (the largest motion) after its inversion pressure.
* **Front leg's action unit** (metastable under the raised phase with a reset of at least a gait
  cycle; inverting above the walking pressure and below the turning pressure by the margin, so
  it stays flat while walking and inverts on the command; the bistable units after it flat at the
  turning pressure): per ``t``, the height whose reset under the raised phase is on its aim
  (bracketed on a batch scan, Brent), then inversion pressures (one batch); of those that meet
  every requirement, the one with the largest pressure margin on both sides.
* **Middle leg's action unit** (monostable at the walking pressure, inverting below it, the
  units after it flat): per ``t``, the tallest height still monostable (the root of its reset
  time at half the limit), inversion pressures, and the walking stride decides.

Verification: every section of the reported leg is re-simulated alone at ``verify_atol`` under
its requirement's phase; the leg at the walking gait (and a front leg at the turning gait) is
simulated and composed, and the monostable leg at the same gait gives the stride ratio.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ....model.design import DesignBatch
from ....solvers.legs.leg import LegResult
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .action import ActionSearch
from .legs import Requirement, violation
from .spec import WalkerSpec
from .zones import ZoneSearch

__all__ = ["LegOutcome", "WalkerSearch", "search_of", "solve_walker", "violation"]


class WalkerSearch(ZoneSearch, ActionSearch):
    """One scene run's sections, searches and leg simulations (cached on the evaluator).

    The zones come from :class:`~.zones.ZoneSearch`, the action units from
    :class:`~.action.ActionSearch`, the runs both are made of from
    :class:`~.search.SearchBase`.
    """


@dataclass
class LegOutcome:
    """What the search found for one leg of a walker scene (before its report).

    Attributes
    ----------
    target_index : int
    kind : str
        ``"front"`` or ``"middle"``.
    purple, green, action : dict
        The zones' and the action unit's searches (:class:`~.zones.ZoneSearch`,
        :class:`~.action.ActionSearch`): the chosen section (``best``; the green zone's is the
        record itself) with its verification run, inversion pressures (MPa) and requirements,
        and the candidates.
    inversion_method : str
    reachable : bool
        A leg was composed and meets every requirement.
    walk, monostable, turn : LegResult or None
        The leg at the walking gait, the monostable leg at the same gait, the front leg at the
        turning gait.
    requirements : list of Requirement
    stride_ratio : float or None
        The leg's stride over the monostable leg's.
    timing : dict of str to LegResult
        The runs of the timing diagrams (``walk``, and ``turn`` for a front leg).
    counts : dict of str to int
    wall_s : float
    """

    target_index: int
    kind: str
    purple: dict
    green: dict
    action: dict
    inversion_method: str
    reachable: bool = False
    walk: LegResult | None = None
    monostable: LegResult | None = None
    turn: LegResult | None = None
    requirements: list[Requirement] = field(default_factory=list)
    stride_ratio: float | None = None
    timing: dict[str, LegResult] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0


def search_of(spec: SceneSpec[WalkerSpec], evaluator: SceneEvaluator) -> WalkerSearch:
    """The scene run's search (one per evaluator, shared by its legs)."""
    if "walker" not in evaluator.cache:
        evaluator.cache["walker"] = WalkerSearch(spec, evaluator)
    return evaluator.cache["walker"]


def solve_walker(
    spec: SceneSpec[WalkerSpec], target_index: int, evaluator: SceneEvaluator
) -> LegOutcome:
    """Design one leg of the scene (``legs[target_index]``: front or middle)."""
    counts0 = dict(evaluator.counts)
    wall0 = evaluator.wall_s
    kind = spec.kind_spec.legs[target_index]
    search = search_of(spec, evaluator)
    purple, green = search.purple(), search.green()
    action = search.front_action() if kind == "front" else search.middle_action()
    out = LegOutcome(
        target_index=target_index,
        kind=kind,
        purple=purple,
        green=green,
        action=action,
        inversion_method=search.method,
    )
    ok = purple["best"] is not None and action["best"] is not None
    if ok:
        designs = (purple["best"]["design"], green["design"], action["best"]["design"])
        walk = search.leg(*designs, search.walk_phases())
        mono = search.monostable()
        out.walk, out.monostable = walk, mono
        if kind == "front":
            out.turn = search.leg(*designs, search.turn_phases())
        out.requirements = (
            purple["best"]["requirements"]
            + green["requirements"]
            + action["best"]["requirements"]
            + search.walking_requirements(walk, mono, kind)
        )
        out.stride_ratio = search.stride_ratio(walk, mono)
        cycles = search.gait.cycles
        t_diag = search.gait.period * cycles + 2.0
        out.timing = {"walk": search.leg(*designs, search.walk_phases(cycles), t_end=t_diag)}
        if kind == "front":
            out.timing["turn"] = search.leg(*designs, search.turn_phases(cycles), t_end=t_diag)
    out.reachable = bool(ok and all(r["met"] for r in out.requirements))
    if ok:  # the leg's objective in the history: 0 once every requirement is met
        evaluator.record(
            DesignBatch.from_designs([designs[0]]),
            target=target_index,
            purpose="result",
            section="leg",
            objective=violation(out.requirements),
        )
    out.counts = {k: evaluator.counts[k] - counts0.get(k, 0) for k in evaluator.counts}
    out.wall_s = evaluator.wall_s - wall0
    return out
