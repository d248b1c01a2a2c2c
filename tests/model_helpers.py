"""Helpers shared by the model, solver and sensitivity tests (imported by name: tests is on the
path, see pyproject's pytest ``pythonpath``)."""

from __future__ import annotations

from scipy.optimize import brentq

from dpfexplore.model.constants import dome_alpha, dome_radius
from dpfexplore.model.constants_set import DEFAULT, ClosedForm, ConstantsSet


def height_for_alpha(target: float, t: float = 0.83, r_b: float = 5.0) -> float:
    """Dome height whose α equals ``target`` (α falls with H on [2.5, 3.5] at t = 0.83)."""
    return brentq(lambda H: dome_alpha(H, t, dome_radius(H, r_b)) - target, 2.5, 3.5, xtol=1e-15)


def other_set() -> ConstantsSet:
    """A set unlike the paper's in every form and with a dimensionless, wider domain."""
    return ConstantsSet(
        name="other",
        k_hat=ClosedForm(
            DEFAULT.k_hat.exponents, tuple(1.3 * c for c in DEFAULT.k_hat.coefficients)
        ),
        alpha=ClosedForm((*DEFAULT.alpha.exponents, (0, 4)), (*DEFAULT.alpha.coefficients, 0.02)),
        tip_ratio=ClosedForm(((0, 0), (1, 0), (0, 1)), (2.10, 0.25, 0.03)),
        domain={
            "H_over_rb": (0.6, 1.0),
            "t_over_rb": (0.1, 0.2),
            "E": (1.0, 100.0),
            "nu": (0.3, 0.49),
        },
        provenance={"made by": "tests/model/test_constants_sets.py"},
    )


#: A three-unit finger inside the paper's box, for tests that vary only the constants set.
FINGER = {"H": [4.0, 4.4, 3.6], "U_L": 8.0, "U_sep": [1.5, 2.0, 1.8], "t": 0.8, "t_lim": 1.5}
