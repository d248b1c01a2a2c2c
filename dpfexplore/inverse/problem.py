"""The objectives of each scene kind: what is solved for a point ``z`` of the design box.

A *problem* is one target of one scene at one number of units. It maps points of the box
``z ∈ [0, 1]^dim`` to exact model outputs and says which of them the optimiser drives:

``residual``
    The vector to bring to zero (tip minus target for the position kinds, mm; apertures minus
    their targets for the gripper, mm). Its squared norm is the paper's objective (mm²).
``stiffness``
    The tip stiffness to maximise (N/mm), only when the scene asks for it.

Every problem models only what its scene needs: a position problem solves one state per design
and no stiffness unless asked; the gripper solves its sequential states and the stiffness of its
activated state only. The base angle and length of the gripper do not change the finger, so
they cost no solve: their derivatives are analytic (MODEL.md §7 transform).

The interface (:class:`Problem`) is what :mod:`dpfexplore.inverse.engine.optimiser` uses, so a new
scene kind adds a problem class here and a parser in :mod:`dpfexplore.inverse.scene_file`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..model import status as st
from ..model.design import DesignBatch
from ..model.gripper import gripper_aperture
from ..model.variables import DesignVariables
from ..numerics.differences import central_differences
from ..solvers.lattice import segment_height
from ..solvers.sensitivities import batch_columns
from .engine.derivatives import BOX_BOUNDS, STEP
from .evaluation import SceneEvaluator
from .spec import GripperSpec

__all__ = ["Evaluation", "GripperProblem", "PositionProblem", "Problem"]


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


class PositionProblem(Problem):
    """Tip of one state at a target (paper eq. opti_pos; opti_pos_stiff with stiffness).

    Parameters
    ----------
    variables : DesignVariables
    target : (x, y), mm
    state : str
        ``"all_inverted"`` or a bit string of ``N`` characters.
    evaluator : SceneEvaluator
    target_index : int
        Index of the target in its scene (recorded in the history).
    """

    n_residuals = 2

    def __init__(
        self,
        variables: DesignVariables,
        target,
        state: str,
        evaluator: SceneEvaluator,
        target_index: int = 0,
    ) -> None:
        self.variables = variables
        self.dim = variables.n_variables
        self.target = np.asarray(target, dtype=float)
        n = variables.n_units
        self.state = 2**n - 1 if state == "all_inverted" else int(state, 2)
        self.state_bits = format(self.state, f"0{n}b")
        self.evaluator = evaluator
        self.target_index = target_index

    def designs(self, z: NDArray) -> DesignBatch:
        """The designs of box points ``z``."""
        return self.variables.designs(z)

    def requests(self, z: NDArray, *, stiffness: bool) -> tuple[DesignBatch, NDArray, NDArray]:
        """One state per design; its stiffness only when asked."""
        return self.designs(z), np.array([self.state]), np.array([stiffness])

    def finish(self, z: NDArray, batch: DesignBatch, out: dict[str, NDArray]) -> Evaluation:
        """Residual ``tip - target`` (mm) where the state exists."""
        ok = out["status"][:, 0] == st.OK
        tip = np.column_stack([out["tip_x"][:, 0], out["tip_y"][:, 0]])
        residual = np.where(ok[:, None], tip - self.target, np.nan)
        k = np.where(ok, out["stiffness"][:, 0], np.nan)
        columns = {
            "state": np.full(len(z), self.state_bits),
            "status": out["status"][:, 0],
            "found": out["found"][:, 0],
            "tip_x": tip[:, 0],
            "tip_y": tip[:, 1],
        }
        return Evaluation(z=z, ok=ok, residual=residual, stiffness=k, columns=columns)

    def _residual_derivatives(self, ev: Evaluation, d_tip: NDArray, dtheta: NDArray) -> NDArray:
        return d_tip[0]


class GripperProblem(Problem):
    """The multi-aperture gripper (paper eq. opti_multi; MODEL.md §7, §9).

    The box is the finger's variables followed by ``θ_B`` and ``Base_L``; the residuals are the
    apertures of the targeted states minus their targets (mm), and the stiffness is that of the
    activated state.
    """

    def __init__(
        self, variables: DesignVariables, spec: GripperSpec, evaluator: SceneEvaluator
    ) -> None:
        self.variables = variables
        self.spec = spec
        self.n_finger = variables.n_variables
        self.dim = self.n_finger + 2
        self.n_residuals = len(spec.states)
        self.evaluator = evaluator
        self.target_index = 0
        states = [int(s, 2) for s in spec.states]
        activated = int(spec.activated, 2)
        if activated not in states:
            states.append(activated)
        self.states = np.array(states, dtype=np.int64)
        self.activated_column = states.index(activated)
        self.targets = np.asarray(spec.apertures, dtype=float)

    def designs(self, z: NDArray) -> DesignBatch:
        """The finger designs of box points (the base variables are not part of a finger)."""
        return self.variables.designs(z[:, : self.n_finger])

    def base(self, z: NDArray) -> tuple[NDArray, NDArray]:
        """``θ_B`` (degrees) and ``Base_L`` (mm) of box points."""
        (t0, t1), (b0, b1) = self.spec.theta_B_deg, self.spec.base_L
        return t0 + (t1 - t0) * z[:, self.n_finger], b0 + (b1 - b0) * z[:, self.n_finger + 1]

    def requests(self, z: NDArray, *, stiffness: bool) -> tuple[DesignBatch, NDArray, NDArray]:
        """The targeted states (and the activated one); stiffness of the activated one if asked."""
        want = np.zeros(self.states.size, dtype=bool)
        want[self.activated_column] = stiffness
        return self.designs(z), self.states, want

    def finish(self, z: NDArray, batch: DesignBatch, out: dict[str, NDArray]) -> Evaluation:
        """Apertures minus targets (mm) where every state exists (MODEL.md §7 transform)."""
        ok = np.all(out["status"] == st.OK, axis=1)
        theta, base_l = self.base(z)
        h = segment_height(batch.r_b, batch.t_lim, batch.t)
        tips = np.stack([out["tip_x"], out["tip_y"]], axis=-1)  # (m, S, 2)
        apertures = (
            np.column_stack(
                [gripper_aperture(tips[i], h[i], base_l[i], theta[i]) for i in range(len(z))]
            ).T
            if len(z)
            else np.empty((0, self.states.size))
        )
        n_target = self.n_residuals
        residual = np.where(ok[:, None], apertures[:, :n_target] - self.targets, np.nan)
        k = np.where(ok, out["stiffness"][:, self.activated_column], np.nan)
        columns = {"status": np.max(out["status"], axis=1), "theta_B_deg": theta, "base_L": base_l}
        for j, bits in enumerate(self.spec.states):
            columns[f"aperture_{bits}"] = apertures[:, j]
            columns[f"found_{bits}"] = out["found"][:, j]
        columns["_tips"] = tips[:, :n_target]
        columns["_h"] = h
        return Evaluation(z=z, ok=ok, residual=residual, stiffness=k, columns=columns)

    def _solved_columns(self) -> NDArray:
        return np.arange(self.n_finger)

    @property
    def _stiffness_column(self) -> int:  # type: ignore[override]
        return self.activated_column

    def _residual_derivatives(self, ev: Evaluation, d_tip: NDArray, dtheta: NDArray) -> NDArray:
        # a_j = 2 Base_L - 2 [sin θ x_j + cos θ (y_j - h)], h = 1.5 r_b + t_lim + t (MODEL.md §7).
        theta = math.radians(float(self.base(ev.z[:1])[0][0]))
        names = self.variables.parameters
        d_h = dtheta[names.index("t")] + dtheta[names.index("t_lim")]
        d_tip = d_tip[: self.n_residuals]
        return -2.0 * (math.sin(theta) * d_tip[:, 0] + math.cos(theta) * (d_tip[:, 1] - d_h))

    def _analytic_columns(self, ev: Evaluation, jac: NDArray) -> None:
        # a_j = 2 Base_L - 2 [sin θ x_j + cos θ (y_j - h)] (MODEL.md §7).
        (t0, t1), (b0, b1) = self.spec.theta_B_deg, self.spec.base_L
        theta = math.radians(float(self.base(ev.z[:1])[0][0]))
        tips = ev.columns["_tips"][0]
        h = float(ev.columns["_h"][0])
        x, y = tips[:, 0], tips[:, 1] - h
        d_theta = -2.0 * (math.cos(theta) * x - math.sin(theta) * y)
        jac[: self.n_residuals, self.n_finger] = d_theta * math.radians(t1 - t0)
        jac[: self.n_residuals, self.n_finger + 1] = 2.0 * (b1 - b0)
