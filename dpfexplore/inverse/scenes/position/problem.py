"""The position problem: the tip of one state at a target (paper eq. opti_pos, opti_pos_stiff).

The residual is the tip of the targeted state minus the target (mm); its squared norm is the
paper's objective (mm²). The stiffness of that state is solved only when asked (the
position-and-stiffness scene's fronts and weighted sum).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ....model import status as st
from ....model.design import DesignBatch
from ....model.variables import DesignVariables
from ...engine.problem import Evaluation, Problem
from ...evaluation import SceneEvaluator

__all__ = ["PositionProblem"]


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
