"""The trusted baseline: the same equations through ``scipy.integrate.solve_ivp``.

Used by the tests and ``dpfexplore bench dynamics`` as the reference our integrators are
measured against, and reachable as ``simulate(..., method="radau")``. The right-hand side and
the analytic Jacobian are the project's kernels (:mod:`dpfexplore._kernels.dynamics.motion`), so the
baseline differs from our integrators only in the integration: SciPy's Radau IIA (order 5,
simplified Newton) with its own error control and event location (``brentq`` on the dense
output). The profile's knots split the run into segments, so no step straddles a kink of P(t).

The full model is integrated as ``y = [x, v]`` with every component in SciPy's error norm; the
overdamped model as ``ẋ = C(x)⁻¹ (F_ext - ∇E)`` with Jacobian
``C⁻¹ (P_J - H - D(x, ẋ))``.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import lu_factor, lu_solve

from ..._kernels.dynamics import events as kev
from ..._kernels.dynamics import motion as kdyn
from ..._kernels.dynamics.batch import rest_state
from ..._kernels.records import MotionModel, MotionScratch
from ...model import status as st
from ...model.design import Design
from ..lattice import lattice_params
from .common import build_result

__all__ = ["simulate_scipy"]


class _EvaluationCap(Exception):
    """Raised from the right-hand side when a run exceeds its evaluation budget."""


class _Model:
    """Right-hand side, Jacobian and event functions of one design for SciPy."""

    def __init__(self, design: Design, knot_t, knot_p, *, overdamped: bool):
        self.params = lattice_params(design)
        self.n_units = design.n_units
        self.n = 4 * self.n_units - 2
        self.knot_t = knot_t
        self.knot_p = knot_p
        self.overdamped = overdamped
        mass = 0.0 if overdamped else kdyn.node_mass(self.n_units)
        self.phys = np.array([kdyn.ETA_INTERNAL, kdyn.ETA_ISO, mass])
        nodes = 2 * self.n_units + 2
        self.pos = np.empty((nodes, 2))
        self.vel = np.empty((nodes, 2))
        self.work = np.empty(self.n)
        self.model = MotionModel(
            self.params.unit_params, self.params.h, self.knot_t, self.knot_p, self.phys
        )
        self.scratch = MotionScratch(self.pos, self.vel, self.work)
        self.cmat = np.empty((self.n, self.n))
        self.margins = np.empty(self.n_units)
        self.nfev = 0
        self.njev = 0
        self.max_nfev = 0  # 0: no cap

    def _damping(self, x):
        kdyn.damping_matrix(
            self.pos,
            self.params.unit_params,
            self.params.h,
            kdyn.ETA_INTERNAL,
            kdyn.ETA_ISO,
            self.work,
            self.cmat,
        )
        return self.cmat.copy()

    def rhs(self, t, y):
        self.nfev += 1
        if self.max_nfev and self.nfev > self.max_nfev:
            raise _EvaluationCap
        n = self.n
        if not self.overdamped:
            out = np.empty(2 * n)
            out[:n] = y[n:]
            kdyn.acceleration(
                y[:n],
                np.ascontiguousarray(y[n:]),
                t,
                self.model,
                self.scratch,
                out[n:],
            )
            return out
        force = np.empty(n)
        kdyn.force_residual(
            np.ascontiguousarray(y),
            np.zeros(n),
            t,
            self.model,
            self.scratch,
            force,
        )
        return lu_solve(lu_factor(self._damping(y)), force)

    def jac(self, t, y):
        self.njev += 1
        n = self.n
        if not self.overdamped:
            out = np.empty((2 * n, 2 * n))
            kdyn.full_jacobian(
                np.ascontiguousarray(y[:n]),
                np.ascontiguousarray(y[n:]),
                t,
                self.model,
                self.scratch,
                self.cmat,
                out,
            )
            return out
        xdot = self.rhs(t, y)
        stiff = np.empty((n, n))
        kdyn.stiffness_jacobian(
            np.ascontiguousarray(y),
            xdot,
            t,
            self.model,
            self.scratch,
            stiff,
        )
        return lu_solve(lu_factor(self._damping(y)), stiff)

    def event(self, k):
        def margin(t, y):
            kev.margins(np.ascontiguousarray(y[: self.n]), self.params.unit_params, self.margins)
            return self.margins[k]

        return margin


def simulate_scipy(
    design: Design,
    profile,
    *,
    t_end: float,
    n_samples: int = 601,
    rtol: float | None = None,
    atol: float | None = None,
    method: str = "Radau",
    overdamped: bool = False,
    max_nfev: int = 2_000_000,
):
    """Simulate with ``solve_ivp``; returns a :class:`~.dynamics_common.SimulationResult`.

    Parameters
    ----------
    design, profile, t_end, n_samples
        As for :func:`dpfexplore.solvers.dynamics.simulate.simulate`.
    rtol, atol : float, optional
        SciPy tolerances on every component (defaults 1e-4 and 1e-9, the settings of
        ``reference/pickplace_dynamics.csv``).
    method : str
        Any stiff ``solve_ivp`` method (``"Radau"``, ``"BDF"``, ``"LSODA"``).
    overdamped : bool
        Integrate the overdamped model instead of the full one.
    max_nfev : int
        Right-hand-side evaluations after which the run stops with ``Status.STEP_LIMIT``.
        SciPy has no step cap of its own, and its Radau can stall: on some designs at
        rtol 1e-7, atol 1e-10 its steps collapse to ~1e-12 s near the end of the run.
    """
    rtol = 1e-4 if rtol is None else float(rtol)
    atol = 1e-9 if atol is None else float(atol)
    knot_t, knot_p = profile.knots()
    model = _Model(design, knot_t, knot_p, overdamped=overdamped)
    model.max_nfev = int(max_nfev)
    n = model.n
    y = np.empty(2 * n)
    rest_state(model.params.unit_params, model.params.h, y)
    if overdamped:
        y = y[:n].copy()
    t_out = np.linspace(0.0, t_end, n_samples) if n_samples else np.empty(0)
    x_out = np.full((n_samples, n), np.nan)
    events = [model.event(k) for k in range(design.n_units)]
    kev.margins(np.ascontiguousarray(y[:n]), model.params.unit_params, model.margins)
    inverted = model.margins > 0.0
    rec = np.zeros((design.n_units, kev.N_REC))
    rec[:, [kev.REC_FIRST_UP, kev.REC_LAST_DOWN, kev.REC_LAST_UP]] = np.nan
    rec[:, kev.REC_INVERTED] = inverted
    rec[:, kev.REC_EVER] = inverted
    log = []
    stats = np.zeros(kev.N_STATS, dtype=np.int64)
    bounds = [0.0] + [float(t) for t in knot_t if 0.0 < t < t_end] + [t_end]
    code = st.OK
    if n_samples and t_out[0] <= 0.0:
        x_out[0] = y[:n]
    for t_a, t_b in pairwise(bounds):
        if t_b <= t_a:
            continue
        try:
            sol = solve_ivp(
                model.rhs,
                (t_a, t_b),
                y,
                method=method,
                jac=model.jac,
                rtol=rtol,
                atol=atol,
                events=events,
                dense_output=True,
            )
        except _EvaluationCap:
            code = st.STEP_LIMIT
            break
        stats[kev.STAT_STEPS] += len(sol.t) - 1
        if sol.status < 0:
            code = st.NOT_CONVERGED
            break
        crossings = sorted((float(tc), k) for k in range(design.n_units) for tc in sol.t_events[k])
        for t_cross, k in crossings:
            now_up = not rec[k, kev.REC_INVERTED]
            rec[k, kev.REC_CROSSINGS] += 1
            rec[k, kev.REC_INVERTED] = now_up
            if now_up:
                rec[k, kev.REC_EVER] = 1.0
                if np.isnan(rec[k, kev.REC_FIRST_UP]):
                    rec[k, kev.REC_FIRST_UP] = t_cross
                rec[k, kev.REC_LAST_UP] = t_cross
            else:
                rec[k, kev.REC_LAST_DOWN] = t_cross
            log.append((t_cross, k, 1.0 if now_up else -1.0))
        inside = (t_out > t_a) & (t_out <= t_b)
        if inside.any():
            x_out[inside] = sol.sol(t_out[inside])[:n].T
        y = sol.y[:, -1].copy()
    stats[kev.STAT_RHS] = model.nfev
    stats[kev.STAT_FACTOR] = model.njev
    stats[kev.STAT_EVENTS] = len(log)
    log_arr = np.array(log, dtype=float).reshape(-1, 3)
    final_x = y[:n].copy()
    final_v = y[n:].copy() if not overdamped else model.rhs(t_end, y)
    return build_result(
        design,
        profile,
        f"scipy-{method.lower()}",
        st.Status(code),
        model.params,
        t_out,
        x_out,
        rec,
        log_arr,
        stats,
        final_x,
        final_v,
        t_end,
    )
