"""What a traced path holds besides its points: branches, zero-force states, the work done.

* **Branches.** A fold of the path in the apex travel ``δ`` (a limit point under displacement
  control) is where the tangent's ``δ`` component changes sign; the branch id counts the folds
  passed, so every branch is a piece of the path monotone in ``δ``.
* **Zero-force states.** Where the apex reaction changes sign between two points, the state
  with ``δ`` free (``∇Π = 0`` in all unknowns, the dome resting with no apex load) is found by
  Newton from the path interpolated to ``F = 0``; its stability is that of the *full* Hessian
  (``δ`` included): stable with the apex free, which is stricter than stable under displacement
  control. Where Newton fails (next to a saddle-node) the state is interpolated and its
  stability read from the path (:func:`find_zero_force_states`).
* **The ghost.** A dome with no stable inverted rest still has, past the flat position, a
  least force (``dF/dδ = 0``, ``F > 0``): the remnant of the rest it lost at the saddle-node,
  where a dome just past the bifurcation lingers (MODEL.md §4) and into which the rest merges
  as the geometry crosses the bistable boundary (so its travel continues ``tip_dis``). Found on
  stable points of one branch where ``dF/dδ`` changes sign from negative to positive, at the
  minimum of the cubic Hermite interpolant of ``F(δ)`` over that step (third-order accurate in
  the step).
* **Work.** ``∫ F dδ`` along the path, per step by Gauss-Legendre quadrature of the cubic
  Hermite interpolants of ``δ`` and ``F`` in the step's best local coordinate (the unknown whose
  tangent components at both ends are largest); it should equal the energy change (a check of
  the reaction, the path and the energy together).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._kernels.shell.path import equilibrate_free
from .._kernels.shell.records import ShellGeometry

__all__ = [
    "GhostState",
    "PathSamples",
    "ZeroForceState",
    "branch_ids",
    "find_ghost",
    "find_stepped_over_rests",
    "find_zero_force_states",
    "work_along_path",
]


@dataclass(frozen=True)
class ZeroForceState:
    """An equilibrium of the dome with no apex force, found on the path.

    Attributes
    ----------
    displacement : float, mm
        Apex travel toward inversion.
    energy : float, N·mm
        Strain energy.
    stable : bool
        The full Hessian (apex free) is positive definite: the dome rests there by itself.
    index : int
        Negative eigenvalues of the full Hessian (-1: singular, or an unstable interpolated state).
    branch : int
        Branch of the path it was found on.
    refined : bool
        False when Newton did not converge and the state was interpolated between two points;
        then ``stable`` comes from the path (:func:`find_zero_force_states`) and ``index`` is 0
        if stable, else -1.
    """

    displacement: float
    energy: float
    stable: bool
    index: int
    branch: int
    refined: bool


@dataclass(frozen=True)
class GhostState:
    """The least apex force past the flat position of a dome without an inverted rest.

    Attributes
    ----------
    displacement : float, mm
        Apex travel where ``dF/dδ = 0``.
    force : float, N
        The force there (positive: the dome pushes back, it does not rest).
    branch : int
        Branch of the path it was found on.
    """

    displacement: float
    force: float
    branch: int


class PathSamples(NamedTuple):
    """The path's points as the minimum finders read them.

    Attributes
    ----------
    displacement, force, stiffness : ndarray (n,)
        Apex travel (mm), reaction (N) and ``dF/dδ`` (N/mm) at the path's points.
    stable : ndarray of bool (n,)
        Stable under displacement control.
    branch : ndarray of int (n,)
        Branch ids (:func:`branch_ids`).
    """

    displacement: NDArray
    force: NDArray
    stiffness: NDArray
    stable: NDArray
    branch: NDArray


def _step_cubic(displacement, force, stiffness, i):
    """``F`` over step ``i`` as a cubic in ``s ∈ [0, 1]`` (Hermite): coefficients, high first."""
    h = displacement[i + 1] - displacement[i]
    f0, f1, m0, m1 = force[i], force[i + 1], stiffness[i] * h, stiffness[i + 1] * h
    return np.array([2.0 * f0 + m0 - 2.0 * f1 + m1, -3.0 * f0 - 2.0 * m0 + 3.0 * f1 - m1, m0, f0])


def _upward_root(poly, lo: float = 0.0) -> float | None:
    """The root in ``[lo, 1]`` where the polynomial rises through zero (the smallest)."""
    slope = np.polyder(poly)
    found = [
        r.real
        for r in np.roots(np.trim_zeros(poly, "f"))
        if abs(r.imag) < 1e-9
        and lo - 1e-9 <= r.real <= 1.0 + 1e-9
        and np.polyval(slope, r.real) >= 0
    ]
    return min(found) if found else None


def _minima(path: PathSamples, beyond: float):
    """Steps past ``beyond`` where the force turns up on a stable branch.

    Yields ``(i, s, F_min, cubic)``: the step, where in it the force is least, that force, and
    the step's cubic (:func:`_step_cubic`).
    """
    x, force, stiffness, stable, branch = path
    for i in range(force.size - 1):
        if (
            stiffness[i] < 0.0 <= stiffness[i + 1]
            and branch[i] == branch[i + 1]
            and stable[i]
            and stable[i + 1]
            and x[i] > beyond
        ):
            poly = _step_cubic(x, force, stiffness, i)
            s = _upward_root(np.polyder(poly))
            s = min(
                max(-stiffness[i] / (stiffness[i + 1] - stiffness[i]) if s is None else s, 0.0), 1.0
            )
            yield i, s, float(np.polyval(poly, s)), poly


def find_ghost(path: PathSamples, beyond: float) -> GhostState | None:
    """The least positive local minimum of the force at travel past ``beyond`` (mm; None if none).

    ``beyond``: only minima at larger travel count (the flat position, ``H``).
    """
    best = None
    for i, s, value, _ in _minima(path, beyond):
        if value > 0.0 and (best is None or value < best.force):
            h = path.displacement[i + 1] - path.displacement[i]
            best = GhostState(float(path.displacement[i] + s * h), value, int(path.branch[i]))
    return best


def find_stepped_over_rests(path: PathSamples, beyond: float) -> list[float]:
    """Travels (mm) of rests the path stepped over: a barrier and a rest within one step.

    Next to the saddle-node both end points of a step can push back (``F > 0``) while the force
    between them, the step's cubic Hermite interpolant, dips below zero: the rest is that
    cubic's upward zero (third order in the step), stable by the path's own judgement (a stable
    branch, force rising through zero). ``beyond`` as in :func:`find_ghost`.
    """
    x, force = path.displacement, path.force
    travels = []
    for i, s, value, cubic in _minima(path, beyond):
        if value <= 0.0 and force[i] > 0.0 and force[i + 1] > 0.0:
            root = _upward_root(cubic, s)
            if root is not None:
                travels.append(float(x[i] + root * (x[i + 1] - x[i])))
    return travels


def branch_ids(t_delta: NDArray) -> NDArray:
    """Branch id of every point: the number of sign changes of ``dδ/ds`` up to it."""
    sign = np.sign(t_delta)
    # a point exactly at a fold (sign 0) belongs to the branch before it
    for i in range(1, sign.size):
        if sign[i] == 0:
            sign[i] = sign[i - 1]
    flips = np.concatenate([[0], (sign[1:] * sign[:-1] < 0).astype(int)])
    return np.cumsum(flips)


def find_zero_force_states(
    geom: ShellGeometry,
    ys: NDArray,
    force: NDArray,
    branch: NDArray,
    index: NDArray,
    ftol: float,
    xtol: float,
) -> list[ZeroForceState]:
    """Zero-force states between sign changes of the reaction (the start, ``δ = 0``, excluded).

    Newton with ``δ`` free refines each; next to a saddle-node (a rest and a barrier a hair
    apart, the full Hessian nearly singular) it may fail, and then the state is interpolated
    linearly in the force and judged from the path: with the other unknowns stable under
    displacement control (index 0 at both ends), the full Hessian is positive definite exactly
    when the Schur complement ``dF/dδ`` is, i.e. when the force rises through zero.
    """
    from .._kernels.shell.energy import assemble

    states: list[ZeroForceState] = []
    for i in range(2, force.size):
        # signs compared, not the product: forces of a stiff material overflow it
        if not (force[i - 1] < 0.0 < force[i] or force[i] < 0.0 < force[i - 1]):
            continue
        # start from the path interpolated to F = 0: near a saddle-node the barrier and the rest
        # are close, and Newton from the nearer end point may land on the other one
        f = force[i - 1] / (force[i - 1] - force[i])
        interpolated = (1.0 - f) * ys[i - 1] + f * ys[i]
        y = interpolated.copy()  # Newton works in place
        its, negative = equilibrate_free(y, geom, ftol, xtol)
        lo, hi = sorted((ys[i - 1, 0], ys[i, 0]))
        width = hi - lo
        refined = its >= 0 and lo - 2.0 * width <= y[0] <= hi + 2.0 * width
        # two crossings are two states: one Newton landed on the other's (a near-fold start)
        refined = refined and not any(
            s.refined and abs(s.displacement - y[0]) <= 10.0 * xtol for s in states
        )
        # on a branch stable under displacement control the path itself says which state this
        # is (Schur complement): a Newton result of the other kind landed on its neighbour
        judged = index[i - 1] == 0 and index[i] == 0 and branch[i - 1] == branch[i]
        rises = (force[i] - force[i - 1]) * (ys[i, 0] - ys[i - 1, 0]) > 0.0
        refined = refined and not (judged and (negative == 0) != rises)
        if refined:
            stable = negative == 0
        else:
            y = interpolated
            stable = judged and rises
            negative = 0 if stable else -1
        membrane, bending = assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)
        states.append(
            ZeroForceState(
                displacement=float(y[0]),
                energy=float(membrane + bending),
                stable=bool(stable),
                index=int(negative),
                branch=int(branch[i]),
                refined=bool(refined),
            )
        )
    return states


# Gauss-Legendre nodes and weights on [0, 1], 4 points: exact for the degree-6 integrand
# (a cubic times the derivative of a cubic).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(4)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


def work_along_path(ys: NDArray, ts: NDArray, force: NDArray, slope: NDArray) -> NDArray:
    """Cumulative ``∫ F dδ`` (N·mm) at every point of the path.

    Parameters
    ----------
    ys, ts : ndarray of shape (n, m)
        Points and unit tangents (``ts[:, 0] = dδ/ds``).
    force, slope : ndarray of shape (n,)
        Reaction ``F`` (N) and ``dF/ds``.
    """
    n = force.size
    work = np.zeros(n)
    for i in range(1, n):
        # local coordinate of the step: the unknown moving most at both ends, the same way
        # (monotone over the step, so it parametrises it)
        q = int(
            np.argmax(
                np.where(ts[i - 1] * ts[i] > 0.0, np.minimum(abs(ts[i - 1]), abs(ts[i])), 0.0)
            )
        )
        tau = ys[i, q] - ys[i - 1, q]
        # derivatives in τ = y_q at both ends, times the step (Hermite form on [0, 1])
        m0d, m1d = ts[i - 1, 0] / ts[i - 1, q] * tau, ts[i, 0] / ts[i, q] * tau
        m0f, m1f = slope[i - 1] / ts[i - 1, q] * tau, slope[i] / ts[i, q] * tau
        x = _GL_X
        h00, h10, h01, h11 = (
            2 * x**3 - 3 * x**2 + 1,
            x**3 - 2 * x**2 + x,
            -2 * x**3 + 3 * x**2,
            x**3 - x**2,
        )
        d00, d10, d01, d11 = (
            6 * x**2 - 6 * x,
            3 * x**2 - 4 * x + 1,
            -6 * x**2 + 6 * x,
            3 * x**2 - 2 * x,
        )
        f = h00 * force[i - 1] + h10 * m0f + h01 * force[i] + h11 * m1f
        ddelta = d00 * ys[i - 1, 0] + d10 * m0d + d01 * ys[i, 0] + d11 * m1d
        work[i] = work[i - 1] + float(np.sum(_GL_W * f * ddelta))
    return work
