"""Data layout shared by every kernel.

Per-unit parameter table
    A design enters the kernels as ``unit_params``, a float64 array of shape ``(N, N_COLS)``,
    one row per unit (unit 1 first), plus the scalar segment height ``h`` (mm). A batch pads
    designs to ``(n_designs, MAX_UNITS, N_COLS)`` and passes ``n_units`` alongside.

Node numbering
    Post ``k`` (``k = 0..N``) carries the dome-line node ``D_k`` (index ``2k``) and the
    limiting-layer node ``L_k`` (index ``2k + 1``). ``D_0``, ``L_0`` and ``L_1`` are clamped; the
    free coordinates are ``(x, y)`` of ``D_1, D_2, L_2, D_3, L_3, ..., D_N, L_N`` in that order
    (the order of ``reference/energy_gradient.csv``), ``4N - 2`` in all.
"""

from __future__ import annotations

from ._jit import kernel

#: Segment length ``p = U_L + t_ch + U_sep`` (mm): rest length of the unit's dome and layer.
COL_P = 0
#: Dome spring stiffness ``k_b`` (N/mm).
COL_KB = 1
#: Dome energy ratio ``α``.
COL_ALPHA = 2
#: Dome reach ``d`` (mm).
COL_D = 3
#: Limiting-layer axial stiffness ``k_lim`` (N/mm).
COL_KLIM = 4
#: Post axial stiffness ``k_post`` (N/mm) of the post closing the unit (post ``k`` for unit ``k``).
COL_KPOST = 5
#: Torsional stiffness ``k_t`` (N·mm/rad) of both angles at the unit's limiting-layer node.
COL_KT = 6
#: Lower bound on ``u = x̄/d`` enforced by a penalty (``-inf``: none). Used only to steer the
#: state search (constrained pre-relaxation); physical evaluations leave it off.
COL_U_LO = 7
#: Upper bound on ``u`` enforced by the penalty (``+inf``: none).
COL_U_HI = 8
#: Penalty stiffness (N/mm); 0 switches the penalty off.
COL_PEN = 9
#: Extension ``u`` past which the unit counts as inverted (barrier, or 3/4 without one).
COL_U_INV = 10
#: Extension ``u`` of the isolated dome's inverted minimum (1, the reach, without one): where
#: the state search holds an inverted dome before releasing it.
COL_U_HELD = 11
N_COLS = 12

NODE_D0 = 0
NODE_L0 = 1
NODE_L1 = 3


@kernel(inline="always")
def n_nodes(n_units):
    """Number of lattice nodes, ``2N + 2``."""
    return 2 * n_units + 2


@kernel(inline="always")
def n_free(n_units):
    """Number of free coordinates, ``4N - 2``."""
    return 4 * n_units - 2


@kernel(inline="always")
def free_node(node):
    """Free-node index of lattice node ``node``, or -1 if it is clamped."""
    if node == 2:
        return 0
    if node >= 4:
        return node - 3
    return -1


@kernel(inline="always")
def dome_node(k):
    """Index of ``D_k``."""
    return 2 * k


@kernel(inline="always")
def layer_node(k):
    """Index of ``L_k``."""
    return 2 * k + 1
