"""Globalised Newton minimisation of the lattice energy.

Each iteration factors the analytic Hessian. Where it is positive definite the Newton step is
taken; where it is not (the guess sits on a dome's unstable branch), a multiple of the identity is
added until the Cholesky factorisation succeeds (Nocedal & Wright, Algorithm 3.3), which gives a
descent direction that bends toward steepest descent. A step cap keeps the first steps from
jumping across basins, and a backtracking Armijo line search on the energy guarantees decrease.
At a stationary point that is not a minimum (a saddle reached by symmetry), the solver leaves
along the eigenvector of the most negative curvature.

Convergence: the Hessian is positive definite and either the largest gradient component is below
``gtol`` (N) or the full Newton step is below ``xtol`` (mm), in which case that last step is
taken. The second test keeps very stiff lattices (posts 100x stiffer), whose gradient cannot get
below the round-off of their large forces, from being reported as unconverged, and saves the
Hessian evaluation that would only confirm what the quadratic convergence already shows.
"""

from __future__ import annotations

import math

import numpy as np

from .. import status as st
from .._jit import kernel
from .lattice import ENERGY, HESSIAN, N_SPLIT, assemble
from .layout import MAX_UNITS, n_free, n_nodes
from .linalg import cholesky, cholesky_solve, max_abs, smallest_eigenpair

#: Armijo sufficient-decrease constant.
ARMIJO = 1e-4
#: Halvings before the line search gives up.
MAX_BACKTRACKS = 40
#: Energy changes this many ulps of the energy are round-off, not increase.
ROUNDOFF_ULPS = 16.0
#: Springs shorter than this fraction of the segment height make the geometry degenerate.
DEGENERATE_LENGTH = 1e-9


@kernel
def shortest_spring(pos, n_units):
    """Length (mm) of the shortest two-node spring (posts, layer segments, domes) at ``pos``."""
    shortest = np.inf
    for k in range(1, n_units + 1):
        for a, b in ((2 * k, 2 * k + 1), (2 * k + 1, 2 * k - 1), (2 * k, 2 * k - 2)):
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            shortest = min(shortest, math.sqrt(dx * dx + dy * dy))
    return shortest


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
def _factor_modified(hess, low, n):
    """Factor ``hess + τI`` with the smallest ``τ`` of a doubling ladder that works.

    Returns ``(τ, ok)``; ``τ = 0`` means the Hessian itself is positive definite.
    """
    if cholesky(hess, 0.0, low, n):
        return 0.0, True
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(hess[i, i]))
    if not scale > 0.0 or not math.isfinite(scale):
        return 0.0, False
    tau = 1e-3 * scale
    for _ in range(60):
        if cholesky(hess, tau, low, n):
            return tau, True
        tau *= 4.0
    return tau, False


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
        Largest coordinate change of a modified (indefinite-Hessian) step.
    ws : tuple
        From :func:`workspace`.

    Returns
    -------
    status : int
        ``OK``, ``NOT_CONVERGED``, ``NONFINITE``, ``DEGENERATE_GEOMETRY`` (two connected nodes
        coincide, so the energy has no direction there) or ``UNSTABLE`` (stationary, not a
        minimum).
        On ``OK`` the workspace's Hessian and its Cholesky factor describe the returned ``x``,
        so callers can reuse them (stiffness, smallest eigenvalue) without reassembling.
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
        tau, ok = _factor_modified(hess, low, n)
        if not ok:
            return st.NONFINITE, n_eval
        for i in range(n):
            grad[i] = -grad[i]
        cholesky_solve(low, grad, step, n)  # grad now holds -g
        snorm = max_abs(step, n)
        if tau == 0.0 and gnorm <= gtol:
            return st.OK, n_eval
        if tau == 0.0 and snorm <= xtol:
            # Converged on the step: take it. Newton converges quadratically here, so the
            # stepped point is far closer than xtol; the Hessian and factor left in the
            # workspace are those of the point a step (<= xtol) before, which moves the
            # stiffness and smallest eigenvalue by a relative O(xtol / segment length).
            for i in range(n):
                x[i] += step[i]
            return st.OK, n_eval
        if n_eval >= max_iter:
            return st.NOT_CONVERGED, n_eval
        slope = 0.0
        if tau > 0.0 and gnorm <= gtol:
            # Stationary but not a minimum: leave along the most negative curvature.
            lam, vec = smallest_eigenpair(hess, n)
            if lam >= 0.0:
                return st.UNSTABLE, n_eval  # positive semi-definite and singular
            for i in range(n):
                slope -= grad[i] * vec[i]
            sign = -1.0 if slope > 0.0 else 1.0
            for i in range(n):
                step[i] = sign * max_step * vec[i]
            slope = 0.5 * lam * max_step * max_step  # expected decrease from curvature
        else:
            # Cap only modified (non-Newton) steps: a positive definite Newton step is trusted
            # to the line search, which saves iterations from good guesses; a modified step
            # far from a minimum is where a large jump would cross into another basin.
            if tau > 0.0 and snorm > max_step:
                scale = max_step / snorm
                for i in range(n):
                    step[i] *= scale
            for i in range(n):
                slope -= grad[i] * step[i]
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
            if tau == 0.0 and gnorm <= 1e3 * gtol and n_eval < max_iter:
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
