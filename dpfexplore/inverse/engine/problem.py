"""Problems: what the optimiser solves for a point ``z`` of a scene's design box.

A *problem* is one target of one scene at one number of units. It maps points of the box
``z ∈ [0, 1]^dim`` to exact model outputs and says which of them the optimiser drives:

``residual``
    The vector to bring to zero (tip minus target for the position kinds, mm; apertures minus
    their targets for the gripper, mm). Its squared norm is the paper's objective (mm²).
``stiffness``
    The tip stiffness to maximise (N/mm), only when the scene asks for it.

Every problem models only what its scene needs: a position problem solves one state per design
and no stiffness unless asked; the gripper solves its sequential states and the stiffness of its
activated state only. Variables that do not change the finger (the gripper's base angle and
length) cost no solve: their problem differentiates them analytically.

:class:`Problem` is the interface :mod:`dpfexplore.inverse.engine.optimiser` drives; each scene
kind's problem subclasses it in its own package (e.g.
:class:`dpfexplore.inverse.scenes.position.problem.PositionProblem`). Nothing here knows a scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...model.design import DesignBatch
from ...model.variables import DesignVariables
from ...numerics.differences import central_differences
from ...solvers.sensitivities import batch_columns
from ..evaluation import SceneEvaluator
from .derivatives import BOX_BOUNDS, STEP

__all__ = ["Evaluation", "Problem"]


@dataclass
class Evaluation:
    """Outputs of a batch of box points.

    Attributes
    ----------
    z : ndarray of shape (m, dim)
    ok : ndarray of bool, shape (m,)
        Every targeted state exists (status OK) for that design.
    residual : ndarray of shape (m, r), mm
        NaN where not ``ok``.
    stiffness : ndarray of shape (m,), N/mm
        NaN where not asked or not ``ok``.
    columns : dict of str to ndarray
        Per-row outputs for reports (tips, apertures, states found, status).
    """

    z: NDArray
    ok: NDArray
    residual: NDArray
    stiffness: NDArray
    columns: dict[str, NDArray] = field(default_factory=dict)

    @property
    def objective(self) -> NDArray:
        """Squared residual norm (mm²), ``inf`` where not ``ok``."""
        return np.where(self.ok, np.sum(np.nan_to_num(self.residual) ** 2, axis=1), np.inf)


class Problem:
    """One target of a scene at one number of units (the optimiser's view of a scene).

    Subclasses set :attr:`variables`, :attr:`dim`, :attr:`n_residuals`, :attr:`target_index`
    and implement :meth:`designs`, :meth:`requests` and :meth:`finish`.
    """

    variables: DesignVariables
    dim: int
    n_residuals: int
    target_index: int
    #: Solves, records and remembers (best point seen, archives): a problem holds no run state.
    evaluator: SceneEvaluator
    #: Whether the history records :attr:`Evaluation.objective`; False where the solves are
    #: statics serving an objective computed elsewhere (recorded as NaN).
    records_objective: bool = True

    @property
    def n_units(self) -> int:
        """Number of units ``N``."""
        return self.variables.n_units

    def designs(self, z: NDArray) -> DesignBatch:
        """The finger designs of box points ``z`` (shape ``(m, dim)``)."""
        raise NotImplementedError

    def requests(self, z: NDArray, *, stiffness: bool) -> tuple[DesignBatch, NDArray, NDArray]:
        """What to solve for box points ``z``: designs, states ``(S,)`` and which get stiffness."""
        raise NotImplementedError

    def finish(self, z: NDArray, batch: DesignBatch, out: dict[str, NDArray]) -> Evaluation:
        """The evaluation of ``z`` from the solved columns of :meth:`SceneEvaluator.solve`."""
        raise NotImplementedError

    def evaluate(self, z: NDArray, *, purpose: str, stiffness: bool = False) -> Evaluation:
        """Solve the box points ``z`` and record them in the history with their ``purpose``."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        batch, states, want = self.requests(z, stiffness=stiffness)
        out = self.evaluator.solve(
            batch, states, stiffness=want, derivative=purpose == "derivative"
        )
        ev = self.finish(z, batch, out)
        self.record(batch, ev, purpose)
        self.evaluator.observe(self, z, ev.objective, ev.stiffness if stiffness else None)
        return ev

    def record(self, batch: DesignBatch, ev: Evaluation, purpose: str) -> None:
        """Add evaluated designs to the scene's history."""
        columns = {k: v for k, v in ev.columns.items() if not k.startswith("_")}
        self.evaluator.record(
            batch,
            target=self.target_index,
            purpose=purpose,
            objective=ev.objective if self.records_objective else np.nan,
            stiffness=ev.stiffness,
            **columns,
        )

    def jacobian(self, ev: Evaluation, *, stiffness: bool = False) -> tuple[NDArray, NDArray]:
        """``d residual / dz`` (r, dim) and ``d log K / dz`` (dim,) at the first row of ``ev``.

        One solve of that design with the model's design sensitivities (implicit function
        theorem, :mod:`dpfexplore.solvers.sensitivities`), chained with ``dθ/dz`` of the
        reparametrisation (:meth:`DesignVariables.jacobian`); variables that need no solve are
        differentiated analytically. Where the sensitivities are not defined (a Hessian that is
        not positive definite at the returned shape), central differences of the exact model
        (:mod:`dpfexplore.inverse.engine.derivatives`) stand in.
        """
        z = ev.z[:1]
        batch, states, want = self.requests(z, stiffness=stiffness)
        out = self.evaluator.solve(
            batch, states, stiffness=want, derivative=True, sensitivities=True
        )
        # The history lists every model evaluation, this re-solve of the point included.
        self.record(batch, self.finish(z, batch, out), "derivative")
        dtheta = self.variables.jacobian(z[:, : self.variables.n_variables])[0]
        cols = batch_columns(self.n_units)
        d_tip = np.stack([out["d_tip_x"][0][:, cols], out["d_tip_y"][0][:, cols]], axis=1) @ dtheta
        d_res = self._residual_derivatives(ev, d_tip, dtheta)  # (r, n_finger)
        jac = np.zeros((self.n_residuals + stiffness, self.dim))
        jac[: self.n_residuals, : d_res.shape[1]] = d_res
        if stiffness:
            k = out["stiffness"][0, self._stiffness_column]
            jac[-1, : d_res.shape[1]] = (
                out["d_stiffness"][0, self._stiffness_column, cols] @ dtheta
            ) / k
        if not np.all(np.isfinite(jac)):
            return self._difference_jacobian(ev, stiffness=stiffness)
        self._analytic_columns(ev, jac)
        if stiffness:
            return jac[:-1], jac[-1]
        return jac, np.zeros(self.dim)

    def _residual_derivatives(self, ev: Evaluation, d_tip: NDArray, dtheta: NDArray) -> NDArray:
        """``d residual / dz`` of the finger variables.

        ``d_tip`` is ``d tip / dz`` of each requested state, ``(S, 2, n_finger)``; ``dtheta``
        the reparametrisation's ``dθ/dz``, ``(3N + 3, n_finger)``.
        """
        raise NotImplementedError

    #: Column (state) of :meth:`requests` whose stiffness the scene maximises.
    _stiffness_column = 0

    def _difference_jacobian(self, ev: Evaluation, *, stiffness: bool) -> tuple[NDArray, NDArray]:
        """Central differences of the exact model (the fallback of :meth:`jacobian`)."""
        z = ev.z[0]
        f0 = ev.residual[0]
        if stiffness:
            f0 = np.append(f0, math.log(ev.stiffness[0]))

        def func(points: NDArray) -> NDArray:
            e = self.evaluate(points, purpose="derivative", stiffness=stiffness)
            values = e.residual
            if stiffness:
                with np.errstate(invalid="ignore", divide="ignore"):
                    values = np.column_stack([values, np.log(e.stiffness)])
            return np.where(e.ok[:, None], values, np.nan)

        low, high = BOX_BOUNDS
        jac = central_differences(
            func, z, f0, step=STEP, lower=low, upper=high, columns=self._solved_columns()
        )
        self._analytic_columns(ev, jac)
        if stiffness:
            return jac[:-1], jac[-1]
        return jac, np.zeros(self.dim)

    def _solved_columns(self) -> NDArray:
        return np.arange(self.dim)

    def _analytic_columns(self, ev: Evaluation, jac: NDArray) -> None:
        """Fill the columns of variables that need no solve (none by default)."""
