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

__all__ = ["RESET_PULSE", "compare_fingers"]

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
