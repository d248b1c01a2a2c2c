"""The paper's follower-force stiffness (eq. stiff_dynamics), as a validation path.

The paper measured a finger's stiffness ``dF_in/dx`` by pushing its tip with a follower force (a
force that stays normal to the last limiting-layer segment as the finger turns) at a slow,
quasi-static rate, recording force against tip displacement and fitting a line. Quasi-static means
every point of that record is an equilibrium, so here the ramp is a sequence of equilibria
``∇E(x) = F n(x)`` solved with SciPy's MINPACK ``hybrj``, a solver independent of our Newton
kernel. For small ramps the slope tends to the Hessian stiffness ``1/(nᵀ H⁻¹ n)`` reported by
:func:`dpfexplore.solvers.statics.find_state`; the difference shows both the follower term and the
nonlinearity over the ramp.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import root

from .._kernels.lattice import lattice_hessian
from .._kernels.layout import free_node, n_free
from ..model.design import Design
from ..model.status import Status
from .lattice import lattice_params
from .statics import SolverOptions, find_state

__all__ = ["FollowerRamp", "follower_force_stiffness"]


@dataclass(frozen=True)
class FollowerRamp:
    """Result of a quasi-static follower-force ramp.

    Attributes
    ----------
    force : ndarray, N
        Follower force at each step (first entry 0).
    displacement : ndarray, mm
        Tip displacement along the initial tip normal.
    stiffness : float, N/mm
        Slope of the least-squares line of force against displacement.
    """

    force: NDArray
    displacement: NDArray
    stiffness: float


def _tip_normal(x: NDArray, n_units: int, h: float, first_layer_end: float):
    """Unit normal ``n`` to the last layer segment and its derivative w.r.t. both end nodes."""
    tip = free_node(2 * n_units + 1)
    prev = free_node(2 * n_units - 1)
    end = x[2 * tip : 2 * tip + 2]
    start = x[2 * prev : 2 * prev + 2] if prev >= 0 else np.array([first_layer_end, h])
    v = end - start
    length = float(np.hypot(*v))
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    normal = rot @ v / length
    # d(R v/|v|)/dv = (R - n v̂ᵀ)/|v|
    dn_dv = (rot - np.outer(normal, v / length)) / length
    return normal, dn_dv, tip, prev


def follower_force_stiffness(
    design: Design,
    state: str | int,
    *,
    max_displacement: float = 0.02,
    n_steps: int = 8,
    options: SolverOptions | None = None,
) -> FollowerRamp:
    """Ramp a follower force at the tip of a stable state and fit its stiffness.

    Parameters
    ----------
    design : Design
    state : str or int
        A stable state of the design.
    max_displacement : float, mm
        Tip displacement the ramp aims at (set from a small probe load; the record is linear
        to well under 1 % over a few hundredths of a millimetre).
    n_steps : int
        Load steps.
    options : SolverOptions, optional
        For the initial state search.

    Raises
    ------
    ValueError
        If the state is not stable, the finger has one unit (its tip is clamped), or an
        equilibrium of the ramp is not found.
    """
    if design.n_units < 2:
        raise ValueError("n_units = 1: the tip node L_1 is clamped, there is nothing to push")
    start = find_state(design, state, options=options)
    if start.status != Status.OK:
        raise ValueError(
            f"state = {state!r}: not stable ({start.status.label}, found {start.found})"
        )
    params = lattice_params(design)
    up, h = params.unit_params, params.h
    n = n_free(design.n_units)
    first_layer_end = float(up[0, 0])
    grad = np.empty(n)
    hess = np.empty((n, n))

    def equations(x: NDArray, force: float):
        lattice_hessian(x, up, h, grad, hess)
        normal, dn_dv, tip, prev = _tip_normal(x, design.n_units, h, first_layer_end)
        residual = grad.copy()
        residual[2 * tip : 2 * tip + 2] -= force * normal
        jac = hess.copy()
        jac[2 * tip : 2 * tip + 2, 2 * tip : 2 * tip + 2] -= force * dn_dv
        if prev >= 0:
            jac[2 * tip : 2 * tip + 2, 2 * prev : 2 * prev + 2] += force * dn_dv
        return residual, jac

    def solve(x0: NDArray, force: float) -> NDArray:
        sol = root(equations, x0, args=(force,), jac=True, method="hybr", options={"xtol": 1e-13})
        if not sol.success:
            raise ValueError(f"follower ramp: no equilibrium at F = {force:.3g} N ({sol.message})")
        return sol.x

    x0 = start.x.copy()
    normal0, _, tip, _ = _tip_normal(x0, design.n_units, h, first_layer_end)
    tip0 = x0[2 * tip : 2 * tip + 2].copy()
    probe = 1e-4
    probe_disp = float((solve(x0, probe)[2 * tip : 2 * tip + 2] - tip0) @ normal0)
    max_force = probe / probe_disp * max_displacement
    forces = np.linspace(0.0, max_force, n_steps + 1)
    displacement = np.zeros_like(forces)
    x = x0
    for j, force in enumerate(forces[1:], start=1):
        x = solve(x, float(force))
        displacement[j] = (x[2 * tip : 2 * tip + 2] - tip0) @ normal0
    slope = float(np.polyfit(displacement, forces, 1)[0])
    return FollowerRamp(force=forces, displacement=displacement, stiffness=slope)
