"""What a traced path holds besides its points: branches, zero-force states, the work done.

* **Branches.** A fold of the path in the apex travel ``δ`` (a limit point under displacement
  control) is where the tangent's ``δ`` component changes sign; the branch id counts the folds
  passed, so every branch is a piece of the path monotone in ``δ``.
* **Zero-force states.** Where the apex reaction changes sign between two points, the state
  with ``δ`` free (``∇Π = 0`` in all unknowns, the dome resting with no apex load) is found by
  Newton from the nearer point; its stability is that of the *full* Hessian (``δ`` included):
  stable with the apex free, which is stricter than stable under displacement control.
* **Work.** ``∫ F dδ`` along the path, per step by Gauss-Legendre quadrature of the cubic
  Hermite interpolants of ``δ`` and ``F`` in the step's best local coordinate (the unknown whose
  tangent components at both ends are largest); it should equal the energy change (a check of
  the reaction, the path and the energy together).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels.shell_path import equilibrate_free
from .._kernels.shell_records import ShellGeometry

__all__ = ["ZeroForceState", "branch_ids", "find_zero_force_states", "work_along_path"]


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
        Negative eigenvalues of the full Hessian (-1: singular, or not refined).
    branch : int
        Branch of the path it was found on.
    refined : bool
        False when Newton did not converge and the state was interpolated between two points
        (then ``stable`` is False and ``index`` -1).
    """

    displacement: float
    energy: float
    stable: bool
    index: int
    branch: int
    refined: bool


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
    ftol: float,
    xtol: float,
) -> list[ZeroForceState]:
    """Zero-force states between sign changes of the reaction (the start, ``δ = 0``, excluded)."""
    from .._kernels.shell import assemble

    states = []
    for i in range(2, force.size):
        if not force[i - 1] * force[i] < 0.0:
            continue
        near = i - 1 if abs(force[i - 1]) < abs(force[i]) else i
        y = ys[near].copy()
        its, index = equilibrate_free(y, geom, ftol, xtol)
        lo, hi = sorted((ys[i - 1, 0], ys[i, 0]))
        width = hi - lo
        refined = its >= 0 and lo - 2.0 * width <= y[0] <= hi + 2.0 * width
        if not refined:  # interpolate linearly in the force (no stability claimed)
            f = force[i - 1] / (force[i - 1] - force[i])
            y = (1.0 - f) * ys[i - 1] + f * ys[i]
            index = -1
        membrane, bending = assemble(y, geom, np.zeros(0), np.zeros((0, 0)), 0)
        states.append(
            ZeroForceState(
                displacement=float(y[0]),
                energy=float(membrane + bending),
                stable=bool(refined and index == 0),
                index=int(index),
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
