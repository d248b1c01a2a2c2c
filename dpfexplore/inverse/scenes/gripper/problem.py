"""The gripper problem: apertures of the sequential states (paper eq. opti_multi; MODEL.md §7, §9).

The box is the finger's variables followed by the base angle ``θ_B`` and length ``Base_L``,
which do not change the finger: they cost no solve and are differentiated analytically through
the aperture transform ``a_j = 2 Base_L - 2 [sin θ x_j + cos θ (y_j - h)]`` (MODEL.md §7).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ....model import status as st
from ....model.design import DesignBatch
from ....model.gripper import gripper_aperture
from ....model.variables import DesignVariables
from ....solvers.lattice import segment_height
from ...engine.problem import Evaluation, Problem
from ...evaluation import SceneEvaluator
from .spec import GripperSpec

__all__ = ["GripperProblem"]


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
