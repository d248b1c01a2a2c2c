"""Scene files of the timing scenes: pick-and-place reset times and the walker leg's zones.

The parsers and records live with their scenes (:mod:`.pickplace.spec`,
:mod:`.walker.spec`) and are named here too; this module is the file format (the
common tables ``[scene]``, ``[variables]``, ``[optimiser]`` are those of
:mod:`dpfexplore.inverse.scene_file`). As there, every problem is one :class:`SceneSpecError`
whose one-line message starts with the dotted key. Times in s, pressures in MPa, lengths in mm.

Pick-and-place (MODEL.md §9, paper eq. opti_pick_and_place)::

    [scene]
    kind = "pickplace"
    [variables]                    # one N; one free height (a tie group) and t free
    n_units = 6
    H = [4.0, 4.5, 5.0, 5.0, {min = 2.0, max = 4.0}, {min = 2.0, max = 4.0}]
    tied = [[5, 6]]
    U_L = 6.0
    U_sep = 1.0
    t = {min = 0.5, max = 1.0}
    t_lim = 1.0

    [pickplace]
    profile = {P0 = 0.7, tau = [0.0, 1.0, 5.0, 5.1], t_end = 15.0}   # the scene's pulse
    hold_units = [1, 2, 3, 4]      # must stay inverted (bistable): the grasp set point
    reset_unit = "last"            # "last": when every other inverted unit has reset (the
                                   # object is released); or a unit number
    targets = [0.3, 1.0, 2.0, 3.0] # target reset times (s); --target-reset T replaces them
    tolerance = 0.01               # relative: met when |reset - target| <= 1 % of target
    grasp_state = "111100"         # whose tip stiffness is reported and maximised
                                   # (default: the hold units inverted)
    screening = "fast"             # "fast" (where its trained scene matches), "release", "rodas4"
    grid = {t = 11, H = 41}        # screening lines of t, points of H per line
    search_atol = 1e-6             # mm: full model inside the root finding
    verify_atol = 1e-7             # mm: full model of every reported design
    prefer_fitted = true           # answer inside the fitted range when a bracket lies there

    [[pickplace.unit_targets]]     # optional: reset times of named units at once
    units = [5, 6]
    reset = [2.657, 1.613]

    [pickplace.difference]         # optional: the paper's form, max RT_2 - RT_1 and stiffness
    profile = {P0 = 1.0, tau = [0.0, 1.0, 5.0, 5.1], t_end = 15.0}   # profile 2
    max_reset = 6.0                # every reset under both profiles within this (s)
    weights = [1.0, 1.0]           # optional: w1 (1/K)^2 + w2 / (RT_2 - RT_1) as the paper

Walker leg (MODEL.md §10)::

    [scene]
    kind = "walker_leg"
    material = "cheetah-95a"
    [walker]
    leg = "walker-leg"             # base leg (example name or leg file): sections purple, green,
                                   # action, composition, fixed design keys
    monostable_leg = "walker-leg"  # the comparison leg, run at the scene's gait
    legs = ["front", "middle"]
    [walker.gait]
    walk_pressure = 0.2            # both phases while walking
    turn_pressure = 0.35           # phase 2 raised for one cycle: front legs turn
    phase1 = [0.0, 0.1, 1.1, 1.2]  # tau of phase 1 (purple zone)
    phase2 = [1.1, 1.2, 2.2, 2.3]  # tau of phase 2 (green zone and action section)
    period = 3.0                   # phase 1 repeats after this
    t_end = 5.0                    # tip path of one cycle
    cycles = 2                     # cycles in the timing diagram
    [walker.variables]             # per section: H (one bound for all its free units) and t
    purple = {H = {min = 1.8, max = 3.2}, t = {min = 0.55, max = 0.7}}
    green = {H = {min = 1.4, max = 2.6}, t = 1.0}
    action = {H = {min = 2.5, max = 4.2}, t = {min = 0.9, max = 1.0}}   # the action unit only
    [walker.requirements]
    pressure_margin_kPa = 10.0
    purple_reset = [1.0, 1.8]      # s after phase 1 ends: lifted through phase 2's hold, down
                                   # before phase 1 rises again
    purple_aim = [1.25, 1.55]      # root-finding aims of units 1 and 2 (inside the window)
    green_class = "monostable"
    front_action_min_reset = 3.0   # s after the raised phase 2 ends: a full gait cycle
    front_action_aim = 3.6
    middle_action_max_reset = 0.05 # monostable
    min_stride_ratio = 1.5         # over the monostable leg at the same gait
    [walker.search]
    t_lines = 4                    # values of t tried per section
    atol = 1e-5                    # mm: full model inside the root finding
    verify_atol = 1e-7             # mm: full model of every reported design
"""

from __future__ import annotations

from .pickplace.spec import (
    SCREENING,
    DifferenceSpec,
    PickPlaceSpec,
    PulseSpec,
    UnitTarget,
    parse_pickplace,
    with_target_reset,
)
from .walker.spec import (
    LEG_KINDS,
    LEG_ROLES,
    GaitSpec,
    WalkerRequirements,
    WalkerSpec,
    parse_walker,
)

__all__ = [
    "LEG_KINDS",
    "LEG_ROLES",
    "SCREENING",
    "DifferenceSpec",
    "GaitSpec",
    "PickPlaceSpec",
    "PulseSpec",
    "UnitTarget",
    "WalkerRequirements",
    "WalkerSpec",
    "parse_pickplace",
    "parse_walker",
    "with_target_reset",
]
