"""Globalised Newton minimisation of the lattice energy.

Each iteration factors the analytic Hessian (block Cholesky). Where it is positive definite the
Newton step is taken. Where it is not (the guess puts a dome on its unstable branch, a spring is
compressed), the first such step is taken on the Hessian shifted by a multiple of the identity
until it factors (Nocedal & Wright, Algorithm 3.3): a short, cheap step that keeps a geometric
guess in its own basin. Later ones use the *convexified* Hessian: the sum of every spring's
Hessian made positive semi-definite (:data:`.lattice.HESSIAN_CONVEX`: absolute curvatures of the
two-node springs, Gauss-Newton torsion), the projected Newton method of quasi-static finite
elements. It costs one more assembly and a factorisation, keeps every mode on its own scale (a
shift large enough to cover the most negative eigenvalue shrinks the step along the softest
bending mode by ``λ_soft/τ``, often 1e-3, and Newton then crawls), and needs no
eigen-decomposition, which costs about 25 assemblies and factorisations at these sizes (the
choice and its measurements: docs/decisions.md, "Newton steps").
Steps where the Hessian is indefinite are capped in length so that steps from a guess do not
jump across basins; a backtracking Armijo line search on the energy guarantees decrease. At a
stationary point that is not a minimum (a saddle reached by symmetry), the solver leaves along
the eigenvector of the most negative curvature.

Convergence: the Hessian is positive definite and either the largest gradient component is below
``gtol`` (N) or the full Newton step is below ``xtol`` (mm); that last Newton step is then taken.
The second test keeps very stiff lattices (posts 100x stiffer), whose gradient cannot get below
the round-off of their large forces, from being reported as unconverged, and saves the Hessian
evaluation that would only confirm what the quadratic convergence already shows.
"""

from __future__ import annotations

import math

import numpy as np

from ...model import status as st
from ...model.domain import MAX_UNITS
from .._jit import kernel
from ..lattice import ENERGY, HESSIAN, HESSIAN_CONVEX, N_SPLIT, assemble, spring_nodes
from ..layout import n_free, n_nodes
from ..linalg.cholesky import cholesky, cholesky_solve, max_abs

#: Armijo sufficient-decrease constant.
ARMIJO = 1e-4
#: Halvings before the line search gives up.
MAX_BACKTRACKS = 40
#: Energy changes this many ulps of the energy are round-off, not increase.
ROUNDOFF_ULPS = 16.0
#: Indefinite iterations that step on the Hessian shifted by a multiple of the identity before
#: the convexified Hessian takes over, and the first shift of that ladder (relative to the largest
#: diagonal entry). A short first step from a geometric guess keeps it in the guess's basin.
SHIFTED_STEPS = 1
FIRST_SHIFT = 1e-3
#: Springs shorter than this fraction of the segment height make the geometry degenerate.
DEGENERATE_LENGTH = 1e-9


@kernel
def shortest_spring(pos, n_units):
    """Length (mm) of the shortest two-node spring (posts, layer segments, domes) at ``pos``."""
    shortest_sq = np.inf
    for k in range(1, n_units + 1):
        for spring in range(3):
            a, b, _ = spring_nodes(k, spring, 0.0, 0.0)
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            shortest_sq = min(shortest_sq, dx * dx + dy * dy)
    return math.sqrt(shortest_sq)


@kernel
def workspace():
    """Scratch arrays for one solve, sized for the largest design (``MAX_UNITS`` units).

    Returns a tuple ``(pos, grad, hess, low, step, trial, split)``.
    """
    nf = n_free(MAX_UNITS)
    return (
        np.empty((n_nodes(MAX_UNITS), 2)),
        np.empty(nf),
        np.empty((nf, nf)),
        np.empty((nf, nf)),
        np.empty(nf),
        np.empty(nf),
        np.empty(N_SPLIT),
    )


@kernel
def _shifted_step(hess, neg_grad, first_shift, max_step, low, step, n):
    """Newton step on ``hess + τI``, capped at ``max_step``.

    ``τ`` climbs a ladder from ``first_shift`` (relative to the largest diagonal entry; 0 tries
    ``hess`` itself first) until the factorisation succeeds. Returns False if nothing factors
    (non-finite Hessian).
    """
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(hess[i, i]))
    if not (scale > 0.0 and math.isfinite(scale)):
        return False
    tau = first_shift * scale
    for _ in range(60):
        if cholesky(hess, tau, low, n):
            cholesky_solve(low, neg_grad, step, n)
            snorm = max_abs(step, n)
            if snorm > max_step:
                for i in range(n):
                    step[i] *= max_step / snorm
            return True
        tau = 1e-12 * scale if tau == 0.0 else 4.0 * tau
    return False


@kernel
def _escape_step(hess, neg_grad, max_step, step, n):
    """Leave a stationary point that is not a minimum along its most negative curvature.

    The step has length ``max_step`` along the eigenvector of the smallest eigenvalue, signed
    downhill (``neg_grad``, if not exactly zero, decides). Returns ``OK``, ``UNSTABLE`` (the
    Hessian is positive semi-definite and singular: there is no direction of descent to take)
    or ``NONFINITE``.
    """
    w, v = np.linalg.eigh(np.ascontiguousarray(hess[:n, :n]))
    if not math.isfinite(w[0]) or not math.isfinite(w[n - 1]):
        return st.NONFINITE
    if w[0] >= 0.0:
        return st.UNSTABLE
    dot = 0.0
    for i in range(n):
        dot += neg_grad[i] * v[i, 0]
    sign = -1.0 if dot < 0.0 else 1.0
    for i in range(n):
        step[i] = sign * max_step * v[i, 0]
    return st.OK


@kernel
def minimize(x, unit_params, h, gtol, xtol, max_iter, max_step, ws):
    """Minimise the lattice energy from ``x`` (modified in place).

    Parameters
    ----------
    x : ndarray of shape (4N - 2,), mm
        Start; on return the last iterate.
    unit_params : ndarray of shape (N, N_COLS)
    h : float, mm
    gtol : float, N
        Converged when the largest gradient component is below this (Hessian PD).
    xtol : float, mm
        ... or when the full Newton step is below this.
    max_iter : int
        Cap on Hessian evaluations.
    max_step : float, mm
        Largest coordinate change of a step taken where the Hessian is indefinite.
    ws : tuple
        From :func:`workspace`.

    Returns
    -------
    status : int
        ``OK``, ``NOT_CONVERGED``, ``NONFINITE``, ``DEGENERATE_GEOMETRY`` (two connected nodes
        coincide, so the energy has no direction there) or ``UNSTABLE`` (stationary, not a
        minimum).
    n_iter : int
        Hessian evaluations used.

    Notes
    -----
    The first trial point of each line search is assembled with its Hessian: a full step is
    accepted almost always, and then that assembly is the next iteration's, so an accepted
    Newton step costs one assembly instead of an energy evaluation plus an assembly.
    """
    pos, grad, hess, low, step, trial, split = ws
    n = n_free(unit_params.shape[0])
    e = assemble(x, unit_params, h, pos, grad, hess, HESSIAN, split)
    n_eval = 1
    n_indefinite = 0
    # A start with (nearly) coincident connected nodes has no spring direction there; Newton
    # would crawl for its whole budget at forces of ~1e14 N/mm stiffness. Say so at once.
    if shortest_spring(pos, unit_params.shape[0]) <= DEGENERATE_LENGTH * h:
        return st.DEGENERATE_GEOMETRY, n_eval
    while True:
        gnorm = max_abs(grad, n)
        if not (math.isfinite(e) and math.isfinite(gnorm)):
            if shortest_spring(pos, unit_params.shape[0]) <= DEGENERATE_LENGTH * h:
                return st.DEGENERATE_GEOMETRY, n_eval
            return st.NONFINITE, n_eval
        positive = cholesky(hess, 0.0, low, n)
        for i in range(n):
            grad[i] = -grad[i]  # grad holds -g from here on
        if positive:
            cholesky_solve(low, grad, step, n)
            if gnorm <= gtol or max_abs(step, n) <= xtol:
                # Converged: take the Newton step already computed. In the quadratic regime
                # the stepped point is far closer to the minimum than either tolerance. (The
                # workspace's Hessian is that of the point before the step: callers that need
                # curvature at the returned x assemble it there.)
                for i in range(n):
                    x[i] += step[i]
                return st.OK, n_eval
        if n_eval >= max_iter:
            return st.NOT_CONVERGED, n_eval
        slope = 0.0
        if positive:
            for i in range(n):
                slope -= grad[i] * step[i]
        elif gnorm > gtol:
            n_indefinite += 1
            if n_indefinite <= SHIFTED_STEPS:
                shift = FIRST_SHIFT
            else:
                # the convexified Hessian (``trial`` takes the gradient, which ``grad`` already
                # holds negated)
                assemble(x, unit_params, h, pos, trial, hess, HESSIAN_CONVEX, split)
                n_eval += 1
                shift = 0.0
            if not _shifted_step(hess, grad, shift, max_step, low, step, n):
                return st.NONFINITE, n_eval
            for i in range(n):
                slope -= grad[i] * step[i]
        else:
            status = _escape_step(hess, grad, max_step, step, n)
            if status != st.OK:
                return status, n_eval
            for i in range(n):
                slope -= grad[i] * step[i]
            if slope >= 0.0:  # a saddle: no first-order decrease along its escape direction
                lam = 0.0
                for i in range(n):
                    s_i = 0.0
                    for j in range(n):
                        s_i += hess[i, j] * step[j]
                    lam += step[i] * s_i
                slope = 0.5 * lam  # expected decrease from the negative curvature
        # Backtracking Armijo search; the full step is tried with its Hessian (see Notes).
        tolerance = ROUNDOFF_ULPS * 2.220446049250313e-16 * abs(e)
        a = 1.0
        accepted = False
        for attempt in range(MAX_BACKTRACKS):
            for i in range(n):
                trial[i] = x[i] + a * step[i]
            mode = HESSIAN if attempt == 0 else ENERGY
            e_trial = assemble(trial, unit_params, h, pos, grad, hess, mode, split)
            n_eval += attempt == 0
            if e_trial <= e + ARMIJO * a * slope + tolerance:
                accepted = True
                break
            a *= 0.5
        if not accepted:
            # No measurable decrease: at round-off level with a PD Hessian this is convergence.
            if positive and gnorm <= 1e3 * gtol and n_eval < max_iter:
                e = assemble(x, unit_params, h, pos, grad, hess, HESSIAN, split)
                if cholesky(hess, 0.0, low, n):
                    return st.OK, n_eval + 1
            return st.NOT_CONVERGED, n_eval
        for i in range(n):
            x[i] = trial[i]
        e = e_trial
        if a < 1.0:
            if n_eval >= max_iter:
                return st.NOT_CONVERGED, n_eval
            e = assemble(x, unit_params, h, pos, grad, hess, HESSIAN, split)
            n_eval += 1
