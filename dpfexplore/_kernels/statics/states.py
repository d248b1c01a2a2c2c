"""Stable states of one design: geometric guess, state search and per-state outputs.

State numbering: an inversion vector ``s`` (unit 1 first) is the integer with unit 1 as the most
significant bit (``11110`` is 30; the implementation's 1-based state number is that plus one).

The search (:func:`find_state`) must find a requested state whenever a minimum with that
inversion vector exists (MODEL.md §6). It starts every attempt from the geometric guess with the
statics extension factor ``c = 1.0`` and tries, in order, until the minimum it reaches has the
requested inversion vector:

1. plain Newton from the guess;
2. *constrained pre-relaxation at the isolated minima*: the guess relaxed with a penalty that
   holds every dome at its isolated-dome minimum on the requested side (inverted:
   ``u >= u_second_min``; not inverted: ``u <= 0``), then released. The lattice pushes each dome
   away from its own minima, which moves its effective barrier; a dome held at its own minimum
   is past that barrier and the release rolls into the requested minimum. If the state does not
   exist, the release shows where the finger goes when let go: that is the state it reports as
   "collapses to";
3. the same with every dome held only ``PENALTY_MARGIN`` (a quarter of its reach) past its
   isolated barrier. Holding a non-inverted dome flat (``u <= 0``) against inverted neighbours
   that stretch it stores energy that can carry it over its barrier on release; this gentler
   hold finds those mixed states (e.g. ``110`` of a 3-unit finger that attempts 1-2 take to
   ``111``).

Only when every attempt ends elsewhere is the state reported as ``COLLAPSED``. Checked on the
paper's design space (every state of 2-6 unit fingers, ``tests/solvers/test_statics.py`` and 35
further starts per collapsed state: seven guesses ``c = 0.5..2`` times five holds): no state
reported as collapsing was found by any other start (docs/decisions.md, "State search", compares
this search with simpler ones).
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from ...model.quantities import STATE_OUTPUT_NAMES
from .._jit import kernel
from ..lattice import (
    GRADIENT,
    HESSIAN,
    SPLIT_DOME,
    SPLIT_LINEAR,
    SPLIT_TORSION,
    assemble,
    dome_extensions,
    unpack_nodes,
)
from ..layout import (
    COL_D,
    COL_KB,
    COL_P,
    COL_PEN,
    COL_U_HELD,
    COL_U_HI,
    COL_U_INV,
    COL_U_LO,
    free_node,
    n_free,
)
from ..linalg.cholesky import (
    cholesky,
    cholesky_solve,
    smallest_eigenvalue,
    smallest_eigenvalue_factored,
)
from .newton import minimize

#: Extension factor ``c`` of every attempt's geometric guess (the statics value of MODEL.md §6).
GUESS_EXTENSION = 1.0
HOLD_NONE = 0
HOLD_AT_MINIMA = 1
HOLD_PAST_BARRIER = 2
#: How each attempt of the search holds the domes before the release (module docstring).
ATTEMPT_HOLD = (HOLD_NONE, HOLD_AT_MINIMA, HOLD_PAST_BARRIER)
#: Distance (in units of ``d``) past the isolated barrier of the ``HOLD_PAST_BARRIER`` hold. On
#: the paper's design space 0.1-0.25 found every mixed state the hold at minima misses, 0.4
#: found 70 % of them, 0.05 misses all-inverted states the hold at minima finds.
PENALTY_MARGIN = 0.25
#: Penalty stiffness relative to the dome's ``k_b``.
PENALTY_FACTOR = 100.0
#: Tolerance factor for the steering (penalised) solve: it only needs the right basin.
STEERING_TOL_FACTOR = 1e4

#: Inverse iteration for the smallest eigenvalue: residual tolerance and iteration cap.
EIG_RTOL = 1e-7
EIG_MAX_ITER = 200

# Columns of the per-state output vector: the rows of the outputs table
# (dpfexplore.model.quantities.STATE_OUTPUTS), by name.
OUT_ENERGY = STATE_OUTPUT_NAMES.index("energy")
OUT_ENERGY_LINEAR = STATE_OUTPUT_NAMES.index("energy_linear")
OUT_ENERGY_DOME = STATE_OUTPUT_NAMES.index("energy_dome")
OUT_ENERGY_TORSION = STATE_OUTPUT_NAMES.index("energy_torsion")
OUT_TIP_X = STATE_OUTPUT_NAMES.index("tip_x")
OUT_TIP_Y = STATE_OUTPUT_NAMES.index("tip_y")
OUT_BEND = STATE_OUTPUT_NAMES.index("bend_angle")
OUT_CURVATURE = STATE_OUTPUT_NAMES.index("curvature")
OUT_MIN_EIG = STATE_OUTPUT_NAMES.index("min_eig")
OUT_STIFFNESS = STATE_OUTPUT_NAMES.index("stiffness")
OUT_GRAD_NORM = STATE_OUTPUT_NAMES.index("grad_norm")
N_OUT = len(STATE_OUTPUT_NAMES)


@kernel(inline="always")
def unit_bit(k, n_units):
    """Bit of unit ``k`` (1-based) in a state integer: unit 1 is the most significant."""
    return 1 << (n_units - k)


@kernel
def geometric_guess(unit_params, h, state, c, x):
    """Fill ``x`` with the paper's geometric guess for ``state`` (MODEL.md §6).

    Each inverted unit's dome segment is lengthened by ``c·d`` by turning the following post
    (and everything beyond it) by ``θ = atan(c·d/h)`` about the unit's limiting-layer node; the
    limiting layer keeps its length. The heading is carried as its cosine and sine, turned by
    ``(cos θ, sin θ) = (h, c·d)/√(h² + c²d²)``: no trigonometric calls.
    """
    n_units = unit_params.shape[0]
    cos_phi = 1.0
    sin_phi = 0.0
    lx = 0.0
    ly = h
    for k in range(1, n_units + 1):
        p = unit_params[k - 1, COL_P]
        lx += p * cos_phi
        ly += p * sin_phi
        if state & unit_bit(k, n_units):
            lift = c * unit_params[k - 1, COL_D]
            inv_r = 1.0 / math.sqrt(h * h + lift * lift)
            cos_t = h * inv_r
            sin_t = lift * inv_r
            cos_phi, sin_phi = cos_phi * cos_t - sin_phi * sin_t, sin_phi * cos_t + cos_phi * sin_t
        dx = lx + h * sin_phi
        dy = ly - h * cos_phi
        fd = free_node(2 * k)
        x[2 * fd] = dx
        x[2 * fd + 1] = dy
        fl = free_node(2 * k + 1)
        if fl >= 0:
            x[2 * fl] = lx
            x[2 * fl + 1] = ly


@kernel
def inversion_state(x, unit_params, h, pos, u):
    """State integer of configuration ``x``: unit k inverted when ``u_k > u_inv,k``."""
    n_units = unit_params.shape[0]
    dome_extensions(x, unit_params, h, pos, u)
    state = 0
    for k in range(1, n_units + 1):
        if u[k - 1] > unit_params[k - 1, COL_U_INV]:
            state |= unit_bit(k, n_units)
    return state


@kernel
def _steering_params(unit_params, state, hold, steer):
    """Copy of ``unit_params`` with penalties holding every dome on its side for ``state``.

    ``hold`` is ``HOLD_AT_MINIMA`` (inverted: ``u >= u_held``, the second minimum; not
    inverted: ``u <= 0``) or ``HOLD_PAST_BARRIER`` (``u_inv ± PENALTY_MARGIN``); see the
    module docstring.
    """
    n_units = unit_params.shape[0]
    at_minima = hold == HOLD_AT_MINIMA
    for k in range(n_units):
        for j in range(unit_params.shape[1]):
            steer[k, j] = unit_params[k, j]
        threshold = unit_params[k, COL_U_INV]
        if state & unit_bit(k + 1, n_units):
            bound = unit_params[k, COL_U_HELD] if at_minima else threshold + PENALTY_MARGIN
            steer[k, COL_U_LO] = bound
            steer[k, COL_U_HI] = np.inf
        else:
            steer[k, COL_U_LO] = -np.inf
            steer[k, COL_U_HI] = 0.0 if at_minima else threshold - PENALTY_MARGIN
        steer[k, COL_PEN] = PENALTY_FACTOR * unit_params[k, COL_KB]


@kernel(inline="always")
def find_state(unit_params, h, requested, controls, x, ws):
    """Search the minimum with inversion vector ``requested`` (see the module docstring).

    Parameters
    ----------
    unit_params : ndarray of shape (N, N_COLS)
    h : float, mm
    requested : int
        Requested state.
    controls : NewtonControls
        Newton controls (:mod:`.records`; see :func:`.statics.newton.minimize`).
    x : ndarray of shape (>= 4N - 2,)
        Receives the minimum found (the requested one, or where the finger collapses to).
    ws : tuple
        From :func:`.statics.newton.workspace`.

    Returns
    -------
    status : int
        ``OK`` (requested state found), ``COLLAPSED`` (``found`` differs), or the Newton
        failure of the last attempt when no attempt converged.
    found : int
        State of ``x`` (-1 when nothing converged).
    n_iter : int
        Newton iterations over all attempts.
    """
    gtol, xtol, max_iter, max_step = controls
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    pos = ws[0]
    u = ws[5]  # the line-search scratch is free between solves; N <= its length
    # Attempt 1 needs no steering table: most states are found here, without allocating.
    geometric_guess(unit_params, h, requested, GUESS_EXTENSION, x)
    status, total_iter = minimize(x, unit_params, h, gtol, xtol, max_iter, max_step, ws)
    best_found = -1
    last_status = status
    if status == st.OK:
        best_found = inversion_state(x, unit_params, h, pos, u)
        if best_found == requested:
            return st.OK, best_found, total_iter
    best = x[:n].copy()
    best_is_release = False
    held = np.empty_like(unit_params)
    for attempt in range(1, len(ATTEMPT_HOLD)):
        hold = ATTEMPT_HOLD[attempt]
        geometric_guess(unit_params, h, requested, GUESS_EXTENSION, x)
        if hold != HOLD_NONE:
            _steering_params(unit_params, requested, hold, held)
            status, it = minimize(
                x,
                held,
                h,
                gtol * STEERING_TOL_FACTOR,
                xtol * STEERING_TOL_FACTOR,
                max_iter,
                max_step,
                ws,
            )
            total_iter += it
        status, it = minimize(x, unit_params, h, gtol, xtol, max_iter, max_step, ws)
        total_iter += it
        if status != st.OK:
            last_status = status
            continue
        found = inversion_state(x, unit_params, h, pos, u)
        if found == requested:
            return st.OK, found, total_iter
        # Remember where the finger goes; the first held-and-released outcome is the physical
        # answer to "where does it collapse to", so it wins over a plain start.
        released = hold != HOLD_NONE
        if best_found < 0 or (released and not best_is_release):
            best_found = found
            best_is_release = released
            for j in range(n):
                best[j] = x[j]
    if best_found >= 0:
        for j in range(n):
            x[j] = best[j]
        return st.COLLAPSED, best_found, total_iter
    return last_status, -1, total_iter


@kernel(inline="always")
def state_outputs(x, unit_params, h, want_stiffness, want_min_eig, out, ws):
    """Fill ``out`` (``N_OUT`` entries) with the outputs of MODEL.md §7 at minimum ``x``.

    Energy total and split (N·mm), tip ``L_N`` (mm), bend angle of the last limiting-layer
    segment (rad, unwrapped through the finger), mean curvature = bend angle / layer length
    (1/mm), smallest Hessian eigenvalue (N/mm), tip stiffness ``1/(nᵀ H⁻¹ n)`` for a force normal
    to the last layer segment (N/mm; ``inf`` for N = 1, whose tip ``L_1`` is clamped), and the
    largest gradient component (N). Unrequested entries are NaN.

    The Hessian is assembled at ``x`` itself: the one Newton's last check left in the workspace
    belongs to the point one (<= 1e-8 mm) step before, and reusing it put a soft mode's
    eigenvalue 3e-5 relative off on a random six-unit design.
    """
    pos, grad, hess, low, step, trial, split = ws
    n_units = unit_params.shape[0]
    n = n_free(n_units)
    need_hessian = want_stiffness or want_min_eig
    mode = HESSIAN if need_hessian else GRADIENT  # the gradient only for its norm
    e = assemble(x, unit_params, h, pos, grad, hess, mode, split)
    factored = need_hessian and cholesky(hess, 0.0, low, n)
    gnorm = 0.0
    for i in range(n):
        gnorm = max(gnorm, abs(grad[i]))
    out[OUT_ENERGY] = e
    out[OUT_ENERGY_LINEAR] = split[SPLIT_LINEAR]
    out[OUT_ENERGY_DOME] = split[SPLIT_DOME]
    out[OUT_ENERGY_TORSION] = split[SPLIT_TORSION]
    out[OUT_GRAD_NORM] = gnorm
    tip = 2 * n_units + 1
    out[OUT_TIP_X] = pos[tip, 0]
    out[OUT_TIP_Y] = pos[tip, 1]
    bend, length = layer_bend(pos, n_units)
    out[OUT_BEND] = bend
    out[OUT_CURVATURE] = bend / length
    out[OUT_MIN_EIG] = np.nan
    out[OUT_STIFFNESS] = np.nan
    if want_min_eig:
        if factored:
            out[OUT_MIN_EIG] = smallest_eigenvalue_factored(
                hess, low, n, EIG_RTOL, EIG_MAX_ITER, step, trial
            )
        else:  # not positive definite: LAPACK gives the (non-positive) value
            out[OUT_MIN_EIG] = smallest_eigenvalue(hess, n)
    if want_stiffness:
        out[OUT_STIFFNESS] = tip_stiffness(pos, low, factored, step, trial, n_units)


@kernel(inline="always")
def layer_bend(pos, n_units):
    """Bend angle (rad) of the limiting layer and its length (mm) at node positions ``pos``.

    The bend is the signed turn from each layer segment to the next, summed (the first
    segment, between clamped nodes, lies along +x), so the heading unwraps past ±π; the
    length is the sum of the segments' lengths.
    """
    bend = 0.0
    length = 0.0
    px = 1.0
    py = 0.0
    for k in range(1, n_units + 1):
        dx = pos[2 * k + 1, 0] - pos[2 * k - 1, 0]
        dy = pos[2 * k + 1, 1] - pos[2 * k - 1, 1]
        bend += math.atan2(px * dy - py * dx, px * dx + py * dy)
        px = dx
        py = dy
        length += math.sqrt(dx * dx + dy * dy)
    return bend, length


@kernel
def tip_stiffness(pos, low, factored, load, response, n_units):
    """``K = 1/(nᵀ H⁻¹ n)`` (N/mm) for a unit force at ``L_N`` normal to the last layer segment.

    ``low`` is the Cholesky factor of the Hessian at ``pos`` (``factored`` False: the Hessian
    is not positive definite, and the stiffness is NaN). ``inf`` when the tip is clamped (N = 1).
    """
    tip = 2 * n_units + 1
    f = free_node(tip)
    if f < 0:
        return np.inf
    if not factored:
        return np.nan
    n = n_free(n_units)
    dx = pos[tip, 0] - pos[tip - 2, 0]
    dy = pos[tip, 1] - pos[tip - 2, 1]
    norm = math.sqrt(dx * dx + dy * dy)
    for i in range(n):
        load[i] = 0.0
    load[2 * f] = -dy / norm
    load[2 * f + 1] = dx / norm
    cholesky_solve(low, load, response, n)
    compliance = load[2 * f] * response[2 * f] + load[2 * f + 1] * response[2 * f + 1]
    return 1.0 / compliance


@kernel(inline="always")
def state_body(lattice, requested, controls, want_stiffness, want_min_eig, x, out, ws):
    """Find a state and evaluate its outputs; returns ``(status, found, n_iter)``.

    Compiled inline into the row loops of :mod:`.batch` (with :func:`find_state` and
    :func:`state_outputs`); :func:`solve_state` is the same as a function of its own.

    ``lattice`` (:class:`~.records.Lattice`) and ``controls`` (:class:`~.records.NewtonControls`)
    as in :func:`find_state`.

    ``out`` is NaN-filled when no minimum was reached. A minimum whose outputs are not all
    finite (which would be a bug or a degenerate design) is reported as ``NONFINITE`` rather
    than stored as a converged row.
    """
    unit_params, h = lattice
    for j in range(out.shape[0]):
        out[j] = np.nan
    status, found, n_iter = find_state(unit_params, h, requested, controls, x, ws)
    if status == st.OK or status == st.COLLAPSED:
        state_outputs(x, unit_params, h, want_stiffness, want_min_eig, out, ws)
        for j in range(out.shape[0]):
            if out[j] != out[j]:
                is_requested_nan = (j == OUT_MIN_EIG and not want_min_eig) or (
                    j == OUT_STIFFNESS and not want_stiffness
                )
                if not is_requested_nan:
                    return st.NONFINITE, found, n_iter
    return status, found, n_iter


@kernel
def solve_state(lattice, requested, controls, want_stiffness, want_min_eig, x, out, ws):
    """:func:`state_body` compiled on its own, for callers outside the row loops."""
    return state_body(lattice, requested, controls, want_stiffness, want_min_eig, x, out, ws)


@kernel
def nodes_of(x, unit_params, h, pos):
    """Node positions ``(2N + 2, 2)`` of free coordinates ``x`` (for plots and shapes)."""
    unpack_nodes(x, unit_params, h, pos)
