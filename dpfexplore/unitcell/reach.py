"""The reach of a dome: its inverted apex travel under each model of its surroundings.

The inverted apex travel (``tip_dis``, mm) of the pinned cap, of the cap set in its unit cell's
plate (the square face as an annulus, :mod:`.geometry`; the area-equivalent and the inscribed
radius, the edge pinned and clamped), and of the two-unit run (:func:`~.contact.two_unit_rest`)
at the gap of a finger (``U_sep = 1``, ``t_ch = 1``): the neighbour's wall rigid, or giving way
as the finger's hinge does (the two torsion springs of MODEL.md §3 at the limiting layer, lever
``h``: ``k_wall = 2 k_t / h²``, ``t_lim = 1.5``). The paper's box is ``r_b = 5``, ``E = 26``,
``ν = 0.35``; :mod:`dpfexplore.identification.causes` sets these beside the paper's closed forms.
"""

from __future__ import annotations

import math

from ..model.constants import k_t_form
from .contact import two_unit_rest
from .geometry import Plate, square_plate
from .shell import unit_cell_curve

__all__ = ["FINGER_GAP", "PLATES", "hinge_stiffness", "reach_variants"]

#: The unit cell's plates compared (None: the pinned cap); t_ch = 1 mm, UC = 15 mm.
PLATES: dict[str, Plate | None] = {
    "cap pinned": None,
    "cap clamped": Plate(5.0, 1.0, "clamped"),
    "square pinned": square_plate(5.0, 1.0, "pinned"),
    "square clamped": square_plate(5.0, 1.0, "clamped"),
    "inscribed pinned": Plate(7.5, 1.0, "pinned"),
    "inscribed clamped": Plate(7.5, 1.0, "clamped"),
}
#: A finger's gap from the dome's base plane to the neighbour's wall (mm): U_sep + t_ch/2.
FINGER_GAP = 1.0 + 0.5


def hinge_stiffness(t: float, E: float = 26.0, nu: float = 0.35, r_b: float = 5.0) -> float:
    """The neighbour's give as a finger's hinge (N/mm): ``2 k_t / h²`` (module docstring).

    ``U_sep = 1``, ``t_ch = 1``, ``t_lim = 1.5`` mm; ``h = 3 r_b / 2 + t_lim + t``.
    """
    t_lim = 1.5
    k_t = k_t_form(E, t_lim, nu, r_b, 1.0, t, 1.0)
    h = 1.5 * r_b + t_lim + t
    return 2.0 * k_t / h**2


def reach_variants(H: float, t: float, *, n_elements: int | None = None) -> dict[str, dict]:
    """``tip_dis`` (mm) and kind of each plate's free dome, and of the two-unit runs."""
    out = {}
    runs = {}
    for name, plate in PLATES.items():
        run = unit_cell_curve(H, t, n_elements=n_elements, plate=plate)
        runs[name] = run
        out[name] = {"tip_dis": run.tip_dis, "tip_kind": run.tip_kind, "run": run}
    for name, stiffness in (("two-unit, hinge", hinge_stiffness(t)), ("two-unit, rigid", math.inf)):
        rest = two_unit_rest(H, t, gap=FINGER_GAP, wall_stiffness=stiffness, n_elements=n_elements)
        if rest.tip_dis is None:
            kind = None
        elif rest.reaction > 0:  # resting on the wall; the apex itself may have sprung back
            kind = "on the wall" if rest.tip_dis > H else "on the wall, apex back"
        else:
            kind = "pushed back" if rest.touching else "clear"
        out[name] = {
            "tip_dis": rest.tip_dis,
            "tip_kind": kind,
            "reaction": rest.reaction,
            "wall_stiffness": stiffness,
        }
    return out
