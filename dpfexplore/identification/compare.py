"""Two constants sets side by side on whole fingers: states, tips, stiffness and reset times.

What a change of constants set does to a design, beyond its units' ``k_b``, ``alpha`` and
``tip_dis`` (:func:`~dpfexplore.identification.report.compare_sets`): the same finger solved
under each set, its N+1 sequential states (tip in mm, tip stiffness in N/mm, energy in N·mm)
and, under the paper's pressure pulse, each unit's reset time (s) and class. This is the
model-uncertainty view of ``dpfexplore identify compare``: the spread between two sets'
answers for one design.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..model.constants_set import ConstantsSet
from ..model.design import Design, DesignBatch
from ..model.pressure import PressureProfile
from ..solvers.dynamics.common import CLASS_NAMES
from ..solvers.dynamics.simulate import reset_times_batch
from ..solvers.statics import enumerate_states

__all__ = ["RESET_PULSE", "compare_fingers", "format_comparison"]

#: The pulse the reset times are compared under: the paper's (P0 = 0.7 MPa, τ = 0, 1, 5, 5.1 s;
#: the default of ``dpfexplore simulate``), with 60 s after it: a unit whose reset another set
#: delays by seconds still shows its time, not ``inf`` (the paper's 5 s would hide it).
RESET_PULSE = {"P0": 0.7, "tau": (0.0, 1.0, 5.0, 5.1), "t_end": 65.1}


def compare_fingers(
    sets: Sequence[ConstantsSet], design: Design
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The design's sequential states and its units' reset times under each set.

    Parameters
    ----------
    sets : sequence of ConstantsSet
        Two (or more) sets with distinct names (the column prefixes).
    design : Design
        Its geometry and material; its own set is ignored.

    Returns
    -------
    states : DataFrame
        One row per sequential state: ``state`` and per set ``NAME:found``, ``NAME:tip_x``,
        ``NAME:tip_y`` (mm), ``NAME:stiffness`` (N/mm), ``NAME:energy`` (N·mm), and
        ``tip_shift`` (mm): the distance between the first two sets' tips. Each set's sequence
        follows its own inversion thresholds, so a state one set visits and the other does not
        has NaN in the other's columns and in ``tip_shift``.
    resets : DataFrame
        One row per unit: per set ``NAME:reset_time`` (s after the pulse; inf: stays
        inverted) and ``NAME:class``.
    """
    names = [c.name for c in sets]
    if len(set(names)) != len(names):
        raise ValueError(f"sets: need distinct names, got {names}")
    states: dict[str, dict[str, Any]] = {}
    tips = []
    resets = pd.DataFrame({"unit": np.arange(1, design.n_units + 1)})
    profile = PressureProfile.pulse(RESET_PULSE["P0"], RESET_PULSE["tau"])
    for constants in sets:
        finger = design.replace(constants=constants)
        results = enumerate_states(finger, "sequential")
        tips.append({r.requested: np.asarray(r.tip, float) for r in results})
        for r in results:
            row = states.setdefault(r.requested, {"state": r.requested})
            row[f"{constants.name}:found"] = r.found
            row[f"{constants.name}:tip_x"] = float(r.tip[0])
            row[f"{constants.name}:tip_y"] = float(r.tip[1])
            row[f"{constants.name}:stiffness"] = float(r.stiffness)
            row[f"{constants.name}:energy"] = float(r.energy)
        out = reset_times_batch(
            DesignBatch.from_designs([finger]), profile, t_end=RESET_PULSE["t_end"]
        )
        n = design.n_units
        resets[f"{constants.name}:reset_time"] = out["reset_time"][0, :n]
        resets[f"{constants.name}:class"] = [
            CLASS_NAMES.get(int(c)) or "never inverted" for c in out["unit_class"][0, :n]
        ]
    table = pd.DataFrame(list(states.values()))
    if len(sets) >= 2:
        # each set's sequence inverts its units in the order of its own thresholds, so the two
        # sequences may visit different states: a shift only where both solved the state
        none = np.full(2, np.nan)
        table["tip_shift"] = [
            float(np.hypot(*(tips[0].get(s, none) - tips[1].get(s, none)))) for s in table["state"]
        ]
    return table, resets


def _number(value: float, width: int, digits: int = 5) -> str:
    """``value`` in ``width`` characters: ``-`` for a state the set did not visit."""
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return f"{'-':>{width}}"
    return f"{value:>{width}.{digits}g}"


def format_comparison(
    title: str,
    names: Sequence[str],
    units: pd.DataFrame,
    states: pd.DataFrame,
    resets: pd.DataFrame,
) -> list[str]:
    """The comparison of one design as lines of at most about 90 characters.

    Three tables: the units' spring constants under each set (a unit outside a set's fitted
    domain starred), each set's own sequence of states (a sequence follows the set's inversion
    thresholds, so two sets may visit different states; the tip shift is given where both
    visited the state), and the units' reset times.

    Parameters
    ----------
    title : str
        The design's name.
    names : sequence of str
        The two sets' names, in the tables' column prefixes.
    units, states, resets : DataFrame
        :func:`~dpfexplore.identification.report.compare_sets` and :func:`compare_fingers`.
    """
    first, second = names[:2]
    lines = [
        f"design {title}: {len(units)} units, t = {units['t'].iloc[0]:g} mm; "
        f"set A = {first}, set B = {second}"
    ]
    lines.append("units: k_b (N/mm), alpha, tip_dis (mm) and class under each set")
    head = f"{'unit':>4} {'H/mm':>7} "
    block = f"{'k_b':>7} {'alpha':>8} {'tip_dis':>7} {'class':<11}"
    lines.append(f"{'':13}| A {'':34}| B")
    lines.append(f"{head}| {block} | {block}")
    outside = False
    for k, row in enumerate(units.to_dict(orient="records")):
        cells = []
        for name in (first, second):
            star = "" if row[f"{name}:in_domain"] else "*"
            outside |= bool(star)
            cells.append(
                f"{_number(row[f'{name}:k_b'], 7)} {_number(row[f'{name}:alpha'], 8, 4)} "
                f"{_number(row[f'{name}:tip_dis'], 7)} {row[f'{name}:class'] + star:<11}"
            )
        lines.append(f"{k + 1:>4} {row['H']:>7.4g} | {cells[0]} | {cells[1]}")
    if outside:
        lines.append("  *: outside that set's fitted domain (its constants are extrapolated)")
    for name, other in ((first, second), (second, first)):
        visited = states[states[f"{name}:found"].notna()]
        visited = visited.assign(step=visited["state"].map(lambda s: s.count("1")))
        visited = visited.sort_values("step", kind="stable")
        lines.append(f"sequential states under {name}, in its own inversion order")
        lines.append(
            f"  (tip mm, stiffness N/mm, energy N·mm; shift: mm to {other}'s tip, same request)"
        )
        lines.append(
            f"{'step':>4}  {'requested':<9} {'found':<9} {'tip x':>8} {'tip y':>8} "
            f"{'stiffness':>9} {'energy':>9} {'shift':>9}"
        )
        for row in visited.to_dict(orient="records"):
            landed = row[f"{name}:found"]
            mark = "" if landed == row["state"] else "!"
            lines.append(
                f"{row['step']:>4}  {row['state']:<9} {landed + mark:<9} "
                f"{row[f'{name}:tip_x']:>8.5g} {row[f'{name}:tip_y']:>8.5g} "
                f"{row[f'{name}:stiffness']:>9.4g} {_energy(row[f'{name}:energy']):>9.4g} "
                f"{_number(row.get('tip_shift', np.nan), 9, 4)}"
            )
        if (visited[f"{name}:found"] != visited["state"]).any():
            lines.append("  !: the solve landed in another state than requested")
    tau = ", ".join(f"{v:g}" for v in RESET_PULSE["tau"])
    after = RESET_PULSE["t_end"] - RESET_PULSE["tau"][-1]
    lines.append(f"reset times (s after a {RESET_PULSE['P0']:g} MPa pulse, tau {tau} s)")
    lines.append(
        f"  (inf: still inverted {after:g} s after it; -: no reset: never inverted or no contact)"
    )
    lines.append(f"{'unit':>4} | {'A: reset/s':>10} {'class':<15}| {'B: reset/s':>10} class")
    for row in resets.to_dict(orient="records"):
        cells = [
            f"{_number(row[f'{name}:reset_time'], 10, 4)} "
            f"{row[f'{name}:class'].replace('_', ' '):<15}"
            for name in (first, second)
        ]
        lines.append(f"{row['unit']:>4} | {cells[0]}| {cells[1]}")
    return [line.rstrip() for line in lines]


def _energy(value: float) -> float:
    """An energy (N·mm) as printed: the rounding residue of a rest state (1e-28) is 0."""
    return 0.0 if abs(value) < 1e-12 else value
