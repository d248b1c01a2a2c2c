"""The unit-cell shell kernels' records: the reference polygon, and what the path follower passes.

Named records (module-level ``namedtuple`` classes, as :mod:`.records` explains) of the shell
model of one dome: its reference polygon and material (:data:`ShellGeometry`, read by every
kernel of :mod:`.shell.energy` and :mod:`.shell.path`), the partials a node's bending hands to the
assembly (:data:`AnglePartials`), and the controls, scratch and outputs of the continuation
(:data:`PathControls`, :data:`PathScratch`, :data:`PathPoints`; :func:`.shell.path.follow`).
Lengths are in mm, forces in N, energies in N·mm, angles in rad; ``N`` is the number of
segments of the meridian and ``m = 2N - 1`` the number of unknowns ``y`` (:mod:`.shell.energy`).
"""

from __future__ import annotations

from collections import namedtuple

# ---- the shell -----------------------------------------------------------------------------

#: The reference polygon and the material, all the kernels need of one shell.
#: ``r0, z0, area, s0, beta0, sa0`` per node (``N + 1``); ``l0, a0, rm0, wm`` per segment (``N``);
#: ``C`` (N/mm), ``D`` (N·mm), ``nu``; ``k_edge`` (N·mm/rad), the rotational stiffness of the
#: whole edge ring against the last segment's turning (0, the default: pinned).
ShellGeometry = namedtuple(
    "ShellGeometry",
    ["r0", "z0", "l0", "a0", "rm0", "wm", "area", "s0", "beta0", "sa0", "C", "D", "nu", "k_edge"],
    defaults=(0.0,),
)

#: A flat wall across the axis on the side the inverted dome bulges into
#: (:mod:`.contact`): the plane ``z`` (mm; the base plane is ``z = 0``), the offset of the
#: shell's facing surface below its nodes ``offset`` (mm, half the thickness), the penalty's
#: ``modulus`` (N/mm³: contact pressure per mm of penetration) and each node's contact ``area``
#: (mm², ``N + 1``).
Wall = namedtuple("Wall", ["z", "offset", "modulus", "area"])

#: The partials of a bending energy ``U(a_j, a_{j+1})`` of the slope angles of the two segments
#: that meet at a node (:func:`.shell.energy._pair_term`): ``uu = ∂U/∂a_j`` and ``uv = ∂U/∂a_{j+1}``
#: (N·mm/rad), and the second partials ``huu``, ``huv``, ``hvv`` (N·mm/rad²).
AnglePartials = namedtuple("AnglePartials", ["uu", "uv", "huu", "huv", "hvv"])

# ---- the path ------------------------------------------------------------------------------

#: Controls of the continuation (:func:`.shell.path.follow`): the first, largest and smallest
#: step ``h0``, ``h_max``, ``h_min`` in the weighted arclength (mm), the step cap ``max_steps``
#: (int), and the corrector's tolerances: ``ftol`` on the free equations' residual (N) and
#: ``xtol`` on the Newton step (mm).
PathControls = namedtuple("PathControls", ["h0", "h_max", "h_min", "max_steps", "ftol", "xtol"])

#: Scratch of the continuation, allocated once per path: the gradient ``g`` (N; ``m``), the
#: Hessian band ``band`` (N/mm; ``m × (2 BAND + 1)``), the corrector matrix ``w`` in the banded
#: LU's storage (``m × WIDTH``) and its pivots ``piv`` (int64, ``m``), the right-hand side and
#: Newton step ``b`` (``m``), and ``work``, the inertia count's copy of the band
#: (``m × (2 BAND + 1)``).
PathScratch = namedtuple("PathScratch", ["g", "band", "w", "piv", "b", "work"])

#: What the continuation records per point (``max_steps + 1`` rows; :func:`.shell.path.follow`):
#: the unknowns ``ys`` and unit tangents ``ts`` (``m`` each), the membrane and bending energy
#: ``energy`` (N·mm, 2 columns), the apex reaction ``force = ∂Π/∂δ`` (N), its derivative
#: ``slope = dF/ds`` along the tangent (N per mm of weighted arclength) and ``index``, the
#: negative eigenvalues of the free Hessian (int64; -1: singular).
PathPoints = namedtuple("PathPoints", ["ys", "ts", "energy", "force", "slope", "index"])
