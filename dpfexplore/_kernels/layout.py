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

#: The physical columns of the per-unit table, by name, in order: the derivative table of
#: :mod:`.tables.design_tables` has one row per physical column, at its index. A constants set's
#: quantity that the table holds as it is names its column here
#: (:attr:`dpfexplore.model.quantities.SetForm.column`).
PHYSICAL_COLUMNS = ("p", "k_b", "alpha", "d", "k_lim", "k_post", "k_t")
#: Segment length ``p = U_L + t_ch + U_sep`` (mm): rest length of the unit's dome and layer.
COL_P = PHYSICAL_COLUMNS.index("p")
#: Dome spring stiffness ``k_b`` (N/mm).
COL_KB = PHYSICAL_COLUMNS.index("k_b")
#: Dome energy ratio ``α``.
COL_ALPHA = PHYSICAL_COLUMNS.index("alpha")
#: Dome reach ``d`` (mm).
COL_D = PHYSICAL_COLUMNS.index("d")
#: Limiting-layer axial stiffness ``k_lim`` (N/mm).
COL_KLIM = PHYSICAL_COLUMNS.index("k_lim")
#: Post axial stiffness ``k_post`` (N/mm) of the post closing the unit (post ``k`` for unit ``k``).
COL_KPOST = PHYSICAL_COLUMNS.index("k_post")
#: Torsional stiffness ``k_t`` (N·mm/rad) of both angles at the unit's limiting-layer node.
COL_KT = PHYSICAL_COLUMNS.index("k_t")
#: Lower bound on ``u = x̄/d`` enforced by a penalty (``-inf``: none). Used only to steer the
#: state search (constrained pre-relaxation); physical evaluations leave it off. This column
#: and those below follow the physical ones.
COL_U_LO = len(PHYSICAL_COLUMNS)
#: Upper bound on ``u`` enforced by the penalty (``+inf``: none).
COL_U_HI = COL_U_LO + 1
#: Penalty stiffness (N/mm); 0 switches the penalty off.
COL_PEN = COL_U_LO + 2
#: Extension ``u`` past which the unit counts as inverted (barrier, or 3/4 without one).
COL_U_INV = COL_U_LO + 3
#: Extension ``u`` of the isolated dome's inverted minimum (1, the reach, without one): where
#: the state search holds an inverted dome before releasing it.
COL_U_HELD = COL_U_LO + 4
N_COLS = COL_U_LO + 5

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
