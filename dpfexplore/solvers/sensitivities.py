"""Design sensitivities of stable states: the Python side of :mod:`dpfexplore._kernels.sensitivity`.

``find_state(design, state, sensitivities=True).sensitivities`` is a :class:`Sensitivities`:
exact derivatives of the state's tip, bend angle, curvature, energy and tip stiffness (and of its
shape) with respect to every design parameter, by the implicit function theorem at the minimum
(``dx*/dθ = -H⁻¹ ∂g/∂θ``) and the chain rule through the closed-form constants of MODEL.md §3.
``solve_batch(..., sensitivities=True)`` gives the same numbers as columns (:data:`COLUMNS`).

Parameters, in this order (:func:`parameter_names`): ``H_1..H_N``, ``U_L_1..U_L_N``,
``U_sep_1..U_sep_N``, ``t``, ``t_lim``, ``E``. Derivatives are per mm of a length and per MPa of
``E``. Conventions:

* defined only at a minimum with a positive definite Hessian (``OK``, or ``COLLAPSED``: then they
  describe the state the finger collapsed to, :attr:`Sensitivities.state`); NaN otherwise;
* a unit whose reach ``d`` is clamped to 0.01 mm (:attr:`Sensitivities.no_contact`) keeps it
  clamped under small changes, so ``d`` contributes nothing there (one-sided: the branch in use);
* a one-unit finger's tip ``L_1 = (p_1, h)`` is clamped: its tip derivatives are those of
  ``p_1`` and ``h``, and its stiffness is ``inf``, whose derivatives are NaN;
* ``E`` scales every stiffness, so shapes do not depend on it: ``d(x, tip, bend, curvature)/dE =
  0``, ``d(energy)/dE = energy/E``, ``d(stiffness)/dE = stiffness/E``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels.sensitivity import states as ksens
from ..model.domain import MAX_UNITS
from ..model.variables import SENSITIVITY_PER_UNIT, SENSITIVITY_SHARED, parameter_names

__all__ = ["COLUMNS", "OUTPUTS", "Sensitivities", "batch_columns", "parameter_names"]

#: Per-unit parameter kinds, in column order.
PER_UNIT = SENSITIVITY_PER_UNIT
#: Shared parameters, after the per-unit ones.
SHARED = SENSITIVITY_SHARED
#: Differentiated outputs and their rows in the kernel's table.
OUTPUTS = {
    "tip_x": ksens.SENS_TIP_X,
    "tip_y": ksens.SENS_TIP_Y,
    "bend_angle": ksens.SENS_BEND,
    "curvature": ksens.SENS_CURVATURE,
    "energy": ksens.SENS_ENERGY,
    "stiffness": ksens.SENS_STIFFNESS,
}
#: :func:`~dpfexplore.solvers.statics.solve_batch` columns: ``"d_" + output``, each of shape
#: ``(n_rows, 3·MAX_UNITS + 3)`` with columns ``parameter_names(MAX_UNITS)``.
COLUMNS = {f"d_{name}": row for name, row in OUTPUTS.items()}


@functools.cache
@functools.cache
def batch_columns(n_units: int) -> NDArray:
    """Indices of an ``N``-unit design's parameters among the ``3·MAX_UNITS + 3`` batch columns.

    Cached per ``N`` (single designs in optimiser loops ask for it on every call): read-only.
    """
    units = np.arange(n_units)
    per_unit = [kind * MAX_UNITS + units for kind in range(len(PER_UNIT))]
    columns = np.concatenate([*per_unit, 3 * MAX_UNITS + np.arange(len(SHARED))])
    columns.flags.writeable = False
    return columns


@dataclass(frozen=True)
class Sensitivities:
    """Derivatives of one stable state's outputs in the design parameters.

    Attributes
    ----------
    parameters : tuple of str
        ``P = 3N + 3`` names (:func:`parameter_names`); column ``j`` of every array below is the
        derivative with respect to ``parameters[j]``.
    tip : ndarray of shape (2, P)
        ``d(tip_x, tip_y)/dθ``, mm per mm (per MPa for ``E``).
    bend_angle : ndarray of shape (P,), rad per unit of θ
    curvature : ndarray of shape (P,), 1/mm per unit of θ
    energy : ndarray of shape (P,), N·mm per unit of θ
    stiffness : ndarray of shape (P,), N/mm per unit of θ
        NaN for a one-unit finger (its stiffness is ``inf``).
    x : ndarray of shape (4N - 2, P)
        ``dx*/dθ`` of the free coordinates (kernel order).
    no_contact : ndarray of bool, shape (N,)
        Units whose reach ``d`` is clamped (``d`` does not move with the parameters there).
    state : str
        The state these derivatives describe (the state found; differs from the requested one
        when it collapsed).
    """

    parameters: tuple[str, ...]
    tip: NDArray
    bend_angle: NDArray
    curvature: NDArray
    energy: NDArray
    stiffness: NDArray
    x: NDArray
    no_contact: NDArray
    state: str

    @property
    def defined(self) -> bool:
        """True when the derivatives exist (a minimum with a positive definite Hessian)."""
        return bool(np.isfinite(self.tip).all())

    def of(self, output: str) -> NDArray:
        """Derivatives of one output (``"tip_x"``, ``"tip_y"`` or a field name), shape (P,)."""
        if output == "tip_x":
            return self.tip[0]
        if output == "tip_y":
            return self.tip[1]
        if output in ("bend_angle", "curvature", "energy", "stiffness"):
            return getattr(self, output)
        raise ValueError(f"output = {output!r}: choose one of {', '.join(sorted(OUTPUTS))}")

    def wrt(self, parameter: str) -> dict[str, float]:
        """Every output's derivative with respect to one parameter (e.g. ``"H_3"``)."""
        if parameter not in self.parameters:
            raise ValueError(f"parameter = {parameter!r}: not one of {', '.join(self.parameters)}")
        j = self.parameters.index(parameter)
        return {name: float(self.of(name)[j]) for name in OUTPUTS}

    def as_dict(self) -> dict[str, dict[str, float]]:
        """``{output: {parameter: derivative}}`` of plain floats (e.g. for JSON)."""
        return {
            name: dict(zip(self.parameters, map(float, self.of(name)), strict=True))
            for name in OUTPUTS
        }


def from_kernel(sens: NDArray, dx: NDArray, n_units: int, no_contact: NDArray, state: str):
    """:class:`Sensitivities` of one row of the kernel's padded tables.

    ``sens`` has shape ``(N_SENS, 3·MAX_UNITS + 3)`` and ``dx`` ``(4·MAX_UNITS - 2, same)``.
    """
    cols = batch_columns(n_units)
    table = sens[:, cols]
    return Sensitivities(
        parameters=parameter_names(n_units),
        tip=table[[ksens.SENS_TIP_X, ksens.SENS_TIP_Y]],
        bend_angle=table[ksens.SENS_BEND],
        curvature=table[ksens.SENS_CURVATURE],
        energy=table[ksens.SENS_ENERGY],
        stiffness=table[ksens.SENS_STIFFNESS],
        x=dx[: 4 * n_units - 2][:, cols],
        no_contact=np.asarray(no_contact[:n_units], dtype=bool).copy(),
        state=state,
    )
