"""Named records and output columns of the grasp kernels.

Frames: every kernel works in the finger's model frame (MODEL.md §5); the Python layer turns
the gripper frame (MODEL.md §7) into it. One finger is solved; the other is its mirror image,
so each of its forces on the disk has the same component along the gripper's axis and the
opposite one across it.
"""

from __future__ import annotations

from collections import namedtuple

#: The disk in the finger's model frame: centre ``cx``, ``cy`` (mm), ``radius`` (mm), the inner
#: surface's distance ``offset`` from the limiting-layer nodes (mm), the unit vector ``ax``,
#: ``ay`` of the gripper's axis pointing away from the base (the direction the disk's weight
#: pulls with the gripper pointing down) and the friction coefficient ``mu``.
Disk = namedtuple("Disk", ["cx", "cy", "radius", "offset", "ax", "ay", "mu"])

#: Controls of a contact solve: the Newton controls ``gtol`` (N), ``xtol`` (mm), ``max_iter``,
#: ``max_step`` (mm); the penalty stiffness ``kappa`` (N/mm) and smoothing width ``eps`` (mm);
#: the penetration tolerance ``tol`` (mm); the cap ``max_outer`` on augmented-Lagrangian
#: updates; the largest radius increment ``grow`` (mm) while the disk is grown into place; the
#: pull-out step ``pull_step`` (mm) and the cap ``max_pull`` on pull-out steps.
GraspControls = namedtuple(
    "GraspControls",
    [
        "gtol",
        "xtol",
        "max_iter",
        "max_step",
        "kappa",
        "eps",
        "tol",
        "max_outer",
        "grow",
        "pull_step",
        "max_pull",
    ],
)

#: One finger's lattice in its grasp: the table ``unit_params`` ``(N, N_COLS)``, the segment
#: height ``h`` (mm) and the inversion vector ``bits`` (int64, ``(N,)``) the state should keep.
GraspLattice = namedtuple("GraspLattice", ["unit_params", "h", "bits"])

#: The contact's multipliers and loads, one row per limiting-layer segment (``(N, 4)``):
#: column ``SHIFT`` the penalty's shift (mm, the multiplier over ``kappa``), columns ``LOAD_X``,
#: ``LOAD_Y`` the friction load on the finger (N) and ``LOAD_S`` where along the segment it acts.
SHIFT = 0
LOAD_X = 1
LOAD_Y = 2
LOAD_S = 3
N_CONTACT_COLS = 4

#: Per-segment results (``(N, N_SEG)``): normal force on the disk (N), contact point ``x``,
#: ``y`` (mm, model frame), unit normal from the surface to the centre, gap (mm), position
#: along the segment (0 at ``L_{k-1}``, 1 at ``L_k``).
SEG_FORCE = 0
SEG_PX = 1
SEG_PY = 2
SEG_NX = 3
SEG_NY = 4
SEG_GAP = 5
SEG_S = 6
N_SEG = 7

#: Per-grasp results (``(N_GRASP,)``): status code, Newton iterations, largest penetration (mm),
#: grip force (N: the sum of one finger's normal forces), unit 1's dome force (N) and
#: extension (mm), the cage's force on the disk against the axis (N, both fingers; positive
#: holds the disk), the friction capacity factor (N: both fingers' ``Σ f |t·a|``, times ``μ``
#: the friction's part of the holding force), whether the inversion vector held (1/0),
#: the total energy (N·mm, lattice and contact penalty) and the lattice energy alone (N·mm).
G_STATUS = 0
G_ITER = 1
G_PENETRATION = 2
G_GRIP = 3
G_DOME1_FORCE = 4
G_DOME1_EXT = 5
G_CAGE = 6
G_FRICTION = 7
G_HOLDS = 8
G_ENERGY = 9
G_LATTICE_ENERGY = 10
N_GRASP = 11

#: What the sorting loop reads of the gripper (:func:`.batch.sort_batch`): the finger's table
#: ``unit_params`` and its table with the tip unit held inverted ``held_params`` (``(N,
#: N_COLS)``), the segment height ``h`` (mm), per grasp state its inversion vector ``bits`` and
#: ``held_bits`` (int64, ``(n_states, N)``), its free shape ``x_free`` and the free shape with the
#: tip held ``x_held`` (mm, ``(n_states, 4N - 2)``), the sensor's ``threshold`` (N: on unit 1's
#: dome force magnitude) and whether the tip unit stays inverted
#: for the lift (``tip_lasts``, bool).
SortSetup = namedtuple(
    "SortSetup",
    [
        "unit_params",
        "held_params",
        "h",
        "bits",
        "held_bits",
        "x_free",
        "x_held",
        "threshold",
        "tip_lasts",
    ],
)
