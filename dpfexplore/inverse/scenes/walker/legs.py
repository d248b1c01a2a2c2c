"""Legs of the walker scene: composed from section runs, each simulated once per scene run.

:class:`LegComposer` (a mixin of :class:`dpfexplore.inverse.scenes.walker.solve.WalkerSearch`) puts
designed sections into the scene's base leg with the gait's phases, simulates each (section,
phase) once (:func:`dpfexplore.solvers.legs.leg.simulate_section`, counted as ``sections``) and
composes the tip path (:mod:`dpfexplore.solvers.legs.kinematics`); :func:`requirement` and
:func:`violation` are the scene's requirement records and their total shortfall.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, TypedDict

from ....model.design import Design
from ....model.pressure import PressureProfile
from ....solvers.legs.kinematics import compose, tip_node
from ....solvers.legs.leg import Leg, LegResult, SectionRun, section_nodes, simulate_section

__all__ = ["LegComposer", "Requirement", "requirement", "violation"]


class Requirement(TypedDict):
    """One requirement of a zone: its text, the verified value and bound, whether it is met.

    The text names the units of the value and bound (s, MPa).
    """

    zone: str
    requirement: str
    value: Any
    bound: Any
    met: bool


class LegComposer:
    """Leg runs of one scene run (a mixin).

    Needs on the instance: ``w`` (WalkerSpec), ``gait``, ``evaluator``, ``legs`` (a dict: the
    cache of section runs) and ``sections`` (a dict of results).
    """

    def walk_phases(self, cycles: int = 1) -> dict[str, PressureProfile]:
        """Both phases at the walking pressure."""
        return {"1": self.gait.phase(1, cycles=cycles), "2": self.gait.phase(2, cycles=cycles)}

    def turn_phases(self, cycles: int = 1) -> dict[str, PressureProfile]:
        """Phase 2 raised in the first cycle (the turning command)."""
        return {
            "1": self.gait.phase(1, cycles=cycles),
            "2": self.gait.phase(2, cycles=cycles, raised_first=True),
        }

    def leg_of(
        self,
        purple: Design,
        green: Design,
        action: Design,
        phases: dict[str, PressureProfile],
        *,
        t_end: float | None = None,
        name: str = "",
    ) -> Leg:
        """The scene's base leg with these sections and phases."""
        designs = {"purple": purple, "green": green, "action": action}
        phase_of = {"purple": "1", "green": "2", "action": "2"}
        sections = tuple(
            replace(s, design=designs[s.name], phase=phase_of[s.name]) for s in self.w.leg.sections
        )
        return replace(
            self.w.leg,
            sections=sections,
            phases=phases,
            t_end=self.gait.t_end if t_end is None else t_end,
            name=name or self.w.leg.name,
        )

    def leg(
        self,
        purple: Design,
        green: Design,
        action: Design,
        phases: dict[str, PressureProfile],
        *,
        t_end: float | None = None,
        leg: Leg | None = None,
    ) -> LegResult:
        """Simulate and compose a leg; each (section, phase) simulated once per scene run."""
        leg = leg or self.leg_of(purple, green, action, phases, t_end=t_end)
        runs = []
        for s in leg.sections:
            profile = leg.phases[s.phase]
            key = (s.design, profile, leg.t_end, leg.n_samples)
            if key not in self.legs:
                result, t_start = simulate_section(
                    s,
                    profile,
                    t_end=leg.t_end,
                    n_samples=leg.n_samples,
                    method=leg.method,
                    atol=leg.atol,
                )
                self.evaluator.count("sections")
                self.evaluator.count("designs")
                self.legs[key] = (result, t_start, section_nodes(result))
            result, t_start, nodes = self.legs[key]
            runs.append(
                SectionRun(
                    s, result, t_start, nodes, s.design.in_fitted_range, s.design.fitted_range_note
                )
            )
        placed = compose(
            leg.composition, [r.nodes for r in runs], [s.mount_deg for s in leg.sections]
        )
        notes = [f"{r.section.name}: {r.fitted_range_note}" for r in runs if not r.fitted_range]
        return LegResult(
            leg=leg,
            t=leg.times(),
            tip=placed[-1][:, tip_node(leg.sections[-1].design.n_units)].copy(),
            placed=placed,
            sections=tuple(runs),
            fitted_range=not notes,
            fitted_range_note="; ".join(notes) or None,
        )

    def monostable(self) -> LegResult:
        """The scene's monostable leg at the walking gait."""
        if "monostable" not in self.sections:
            mono = self.w.monostable_leg
            d = {s.name: s.design for s in mono.sections}
            leg = self.leg_of(
                d["purple"], d["green"], d["action"], self.walk_phases(), name="monostable"
            )
            leg = replace(leg, sections=tuple(replace(s, design=d[s.name]) for s in leg.sections))
            self.sections["monostable"] = self.leg(
                d["purple"], d["green"], d["action"], self.walk_phases(), leg=leg
            )
        return self.sections["monostable"]


def requirement(zone: str, text: str, value, bound, met) -> Requirement:
    """One requirement: its zone, text, value, bound and whether it is met."""
    return {"zone": zone, "requirement": text, "value": value, "bound": bound, "met": bool(met)}


def violation(requirements: Sequence[Requirement]) -> float:
    """How far a design is from meeting every requirement: 0 when all are met.

    Each unmet numeric requirement adds its shortfall relative to its bound, each unmet class
    or flag requirement adds 1 (the objective both our search and the benchmark's black box are
    measured by).
    """
    total = 0.0
    for r in requirements:
        if r["met"]:
            continue
        value, bound = r["value"], r["bound"]
        if (
            isinstance(value, (int, float))
            and isinstance(bound, (int, float))
            and not isinstance(value, bool)
            and math.isfinite(value)
            and bound != 0
        ):
            total += abs(value - bound) / abs(bound)
        else:
            total += 1.0
    return total
