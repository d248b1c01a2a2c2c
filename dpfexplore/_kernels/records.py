"""Named records that kernels take instead of long positional argument lists.

Numba compiles ``collections.namedtuple`` instances of arrays and scalars in nopython mode, at no
cost at run time: a record is passed as one struct and its fields are read by name. The classes
are defined here, at module level, because Numba's ``cache=True`` pickles a record's type by
reference to its class: a class made inside a function could not be found again by a later
process loading the cache. Python wrappers build a record once per call with plain Python
scalars of a fixed type (``float`` tolerances, ``int`` counts), so one record type means one
compiled signature.

Records shared by the statics and the dynamics kernels live here; a record that only one family
of kernels uses may live beside those kernels (:mod:`.snap.records`, :mod:`.shell.records`).
"""

from __future__ import annotations

from collections import namedtuple

# ---- inputs shared by the families ---------------------------------------------------------

#: The lattice of one design: ``unit_params`` of shape ``(N, N_COLS)`` (columns in
#: :mod:`.layout`) and the segment height ``h`` (mm, float).
Lattice = namedtuple("Lattice", ["unit_params", "h"])

#: The padded lattices of a batch (:func:`dpfexplore.solvers.lattice.pack_batch`):
#: ``unit_params`` of shape ``(n, MAX_UNITS, N_COLS)``, ``h`` (mm) of shape ``(n,)`` and the
#: unit counts ``n_units`` (int64, ``(n,)``).
LatticeBatch = namedtuple("LatticeBatch", ["unit_params", "h", "n_units"])

#: Newton controls of the energy minimisation: gradient tolerance ``gtol`` (N), step tolerance
#: ``xtol`` (mm), iteration cap ``max_iter`` (int) and the largest step ``max_step`` (mm).
NewtonControls = namedtuple("NewtonControls", ["gtol", "xtol", "max_iter", "max_step"])

#: A piecewise-linear pressure profile: knot times ``t`` (s) and pressures ``p`` (MPa), arrays of
#: one length.
PressureKnots = namedtuple("PressureKnots", ["t", "p"])

#: The model of the motion of a batch: damping ``eta``, ``eta_iso`` (N·s/mm) and the mass per
#: unit ``mass_per_unit`` (tonne; a design of ``N`` units has node masses of
#: ``mass_per_unit · N / (2N + 2)``); 0 for the overdamped model. The release models are
#: overdamped and read only the damping.
Physics = namedtuple("Physics", ["eta", "eta_iso", "mass_per_unit"])

#: A point of an equilibrium branch and its tangent: ``y`` = ``(x, p)`` and ``t``, both of shape
#: (4N - 1,) (:mod:`.snap.continuation`).
BranchPoint = namedtuple("BranchPoint", ["y", "t"])

#: A bracket of an event along a branch step: arclengths ``s_lo`` < ``s_hi`` and the event's
#: values ``g_lo``, ``g_hi`` there (opposite signs) (:func:`.snap.continuation.locate`).
Bracket = namedtuple("Bracket", ["s_lo", "g_lo", "s_hi", "g_hi"])

#: A fitted ensemble of regression trees as flat arrays (:mod:`.reset.trees`): per node the
#: ``feature`` tested (int64), its ``threshold``, the children ``left``, ``right`` (int64; -1 at
#: a leaf) and the leaf ``value``; each tree's first node in ``roots`` (int64); the ``bias``.
TreeArrays = namedtuple(
    "TreeArrays", ["feature", "threshold", "left", "right", "value", "roots", "bias"]
)

# ---- statics -------------------------------------------------------------------------------

#: The design arrays of a batch (those of :class:`dpfexplore.model.design.DesignBatch`):
#: ``n_units`` (int64, ``(n,)``), ``H``, ``U_L``, ``U_sep`` (mm, ``(n, MAX_UNITS)``) and the
#: shared ``t``, ``t_lim`` (mm), ``E`` (MPa), ``nu``, ``r_b``, ``t_ch`` (mm), each ``(n,)``.
DesignArrays = namedtuple(
    "DesignArrays", ["n_units", "H", "U_L", "U_sep", "t", "t_lim", "E", "nu", "r_b", "t_ch"]
)

#: The parameters of one design that all its units share (scalars; units as in
#: :data:`DesignArrays`).
SharedParams = namedtuple("SharedParams", ["t", "t_lim", "E", "nu", "r_b", "t_ch"])

#: What :func:`.tables.design_tables.design_tables` writes: the ``status`` code (int8, ``(n,)``),
#: the per-unit ``table`` ``(n, MAX_UNITS, N_COLS)``, the segment heights ``h`` ``(n,)``, the
#: clamped reaches ``no_contact`` (bool, ``(n, MAX_UNITS)``) and the derivative table ``dtab``
#: ``(n, MAX_UNITS, N_DCONST, N_DPARAM)`` (or ``(0, 0, 0, 0)``: skipped).
TableOutputs = namedtuple("TableOutputs", ["status", "table", "h", "no_contact", "dtab"])

#: The kernel tables of a batch, as the state kernels read them: the lattices (as
#: :data:`LatticeBatch`) and each design's ``status`` code (int8, ``(n,)``).
DesignTable = namedtuple("DesignTable", ["unit_params", "h", "n_units", "status"])

#: The rows to solve: the ``design`` (int64, ``(n_rows,)``) and requested ``state`` (int64) of
#: each row, and which optional outputs to compute (``want_stiffness``, ``want_min_eig``: bool).
RowPlan = namedtuple("RowPlan", ["design", "state", "want_stiffness", "want_min_eig"])

#: What the row kernels write per row: ``out`` ``(n_rows, N_OUT)`` (columns ``OUT_*`` of
#: :mod:`.statics.states`), ``status`` (int8), ``found`` (int64), ``n_iter`` (int32) and ``shapes``
#: ``(n_rows, 4·MAX_UNITS - 2)`` or ``(n_rows, 0)`` (the minimum's free coordinates,
#: NaN-padded, or nothing).
StateRows = namedtuple("StateRows", ["out", "status", "found", "n_iter", "shapes"])

#: The derivative tables ``dtab`` ``(n, MAX_UNITS, N_DCONST, N_DPARAM)`` of a batch
#: (:func:`.tables.design_tables.design_tables`) and its Young's moduli ``E`` (MPa, ``(n,)``).
DesignDerivatives = namedtuple("DesignDerivatives", ["dtab", "E"])

#: What the sensitivity rows write: ``sens`` ``(n_rows, N_SENS, 3·MAX_UNITS + 3)`` (rows
#: ``SENS_*`` of :mod:`.sensitivity.states`) and ``dxs`` ``(n_rows, 4·MAX_UNITS - 2, 3·MAX_UNITS +
#: 3)`` or ``(0, 0, 0)`` (skipped).
SensitivityRows = namedtuple("SensitivityRows", ["sens", "dxs"])

#: The nodes ``a``, ``c``, ``b`` (int) of a torsional spring on the angle ``a-c-b`` (arms
#: ``c→a`` and ``c→b``; :mod:`.sensitivity.states`).
Angle = namedtuple("Angle", ["a", "c", "b"])

#: A torsional spring's arms at a point (:mod:`.sensitivity.states`): the arm vectors ``vax, vay``
#: (``c→a``) and ``vbx, vby`` (``c→b``) in mm, the deviation ``delta`` (rad) and the gradients
#: ``∇φ`` of both arms, ``gax, gay`` and ``gbx, gby`` (1/mm).
TorsionArms = namedtuple(
    "TorsionArms", ["vax", "vay", "vbx", "vby", "delta", "gax", "gay", "gbx", "gby"]
)

#: The design parameter of a tangent (:func:`.sensitivity.states.tangent`): its ``kind`` (column
#: ``DP_*`` of the derivative table), its ``unit`` (1-based, or -1 for the shared ``t`` and
#: ``t_lim``) and the units ``k_lo .. k_hi`` whose springs it touches (1-based, inclusive).
TangentParameter = namedtuple("TangentParameter", ["kind", "unit", "k_lo", "k_hi"])

# ---- dynamics ------------------------------------------------------------------------------

#: What the equations of motion of one design read: its lattice ``unit_params``, ``h``, the
#: pressure profile's knots ``knot_t``, ``knot_p`` and the model array ``phys`` (``PHYS_*`` of
#: :mod:`.dynamics.motion`).
MotionModel = namedtuple("MotionModel", ["unit_params", "h", "knot_t", "knot_p", "phys"])

#: Scratch of the right-hand side and its Jacobians: node positions ``pos`` and node velocities
#: ``vel`` of shape ``(2N + 2, 2)``, and ``work`` of shape ``(4N - 2,)``; ``pos`` holds the node
#: positions on return (:mod:`.dynamics.motion`).
MotionScratch = namedtuple("MotionScratch", ["pos", "vel", "work"])

#: What a Rosenbrock step start fills (:func:`.dynamics.rosenbrock.step_start`): the residual
#: ``res`` and ``ft = ∂R/∂t`` of shape ``(4N - 2,)``, ``jac = ∂R/∂x`` and the damping matrix
#: ``cmat`` of shape ``(4N - 2, 4N - 2)``.
StepStart = namedtuple("StepStart", ["res", "jac", "cmat", "ft"])

#: What a run writes: samples ``x_out`` ``(n_samples, 4N - 2)`` at the times ``t_out``, the
#: per-unit record ``unit_rec`` ``(N, N_REC)``, the ``event_log`` ``(capacity, 3)`` and the
#: ``stats`` counters (int64, ``(N_STATS,)``) (:mod:`.dynamics.events`).
RunRecord = namedtuple("RunRecord", ["t_out", "x_out", "unit_rec", "event_log", "stats"])

#: One accepted step, as the event location reads it: its start ``t0`` and length ``h`` (s),
#: and the positions and velocities at both ends, ``x0``, ``xd0``, ``x1``, ``xd1`` (4N - 2,),
#: which the cubic Hermite interpolant joins.
AcceptedStep = namedtuple("AcceptedStep", ["t0", "h", "x0", "xd0", "x1", "xd1"])

#: What the release integrator writes beside the state: the per-unit record ``unit_rec``
#: ``(N, N_REC)``, the ``stats`` counters (:mod:`.dynamics.events`), the per-unit event diagnostics
#: ``unit_diag`` ``(N, N_RELEASE_DIAG)`` and the static-check ``counters`` (int64, ``(2,)``)
#: (:mod:`.reset.release`).
ReleaseRecord = namedtuple("ReleaseRecord", ["unit_rec", "stats", "unit_diag", "counters"])

#: What the reset-time batches write per design: the run's ``status`` and ``final_state``
#: ``(n,)``, and per unit ``reset``, ``snap_through``, ``snap_back`` (s) and ``unit_class``
#: ``(n, MAX_UNITS)``.
ResetRows = namedtuple(
    "ResetRows", ["status", "final_state", "reset", "snap_through", "snap_back", "unit_class"]
)

#: What the fast reset model writes per design: ``status``, ``final_state`` ``(n,)``;
#: ``reset``, ``snap_back`` (s), ``unit_class`` ``(n, MAX_UNITS)``; ``unit_diag``
#: ``(n, MAX_UNITS, N_UNIT_DIAG)`` and ``design_diag`` ``(n, N_DESIGN_DIAG)``
#: (:mod:`.reset.fast_reset`). One design's slices, without ``status`` and ``final_state``, are a
#: :data:`FastResetUnits`.
FastResetRows = namedtuple(
    "FastResetRows",
    ["status", "final_state", "reset", "snap_back", "unit_class", "unit_diag", "design_diag"],
)
FastResetUnits = namedtuple(
    "FastResetUnits", ["reset", "snap_back", "unit_class", "unit_diag", "design_diag"]
)
