"""The pick-and-place problem: box points ``(H, t)`` to reset times, grasp stiffness and brackets.

:class:`ResetProblem` is the pick-and-place scene's
:class:`~dpfexplore.inverse.engine.problem.Problem`
(one height variable, usually the tied ``H_5 = H_6``, and ``t``). Its static part (the grasp
state's tip stiffness) goes through the problem interface (``requests``/``finish``); its dynamic
part through :meth:`ResetProblem.resets`, which runs the reduced model for screening or the full
model (:meth:`SceneEvaluator.reset_times`), records every design in the history and derives the
scene's objective reset time:

* ``reset_unit = "last"``: the time at which every inverted unit other than the hold units has
  reset (the finger is back at its set point, the object released): the largest of their reset
  times, ``inf`` if one of them is bistable; units that never invert (or have no contact) do not
  count;
* a named unit: its reset time.

A design is *admissible* when every hold unit stays inverted to the horizon (bistable: the grasp
set point holds) and the objective exists. Along a line of constant ``t``, the objective of
admissible designs is continuous except where a unit changes class in a way that makes it jump
(a tip unit that stops inverting, a hold unit that resets); where a tip unit turns bistable it
diverges (the ghost of the lost minimum, MODEL.md §4), so a bracket may end on a bistable point.
:func:`line_brackets` finds the sign changes of ``log(objective / target)`` on the screening grid,
and :func:`root_on_line` closes one by Brent's method on the full model.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ....model import status as st
from ....model.design import Design, DesignBatch
from ....solvers.dynamics.common import (
    CLASS_BISTABLE,
    CLASS_METASTABLE,
    CLASS_MONOSTABLE,
)
from ...engine.problem import Evaluation, Problem
from ...engine.roots import LOG_INF
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .spec import PickPlaceSpec, PulseSpec

__all__ = [
    "Bracket",
    "ResetEval",
    "ResetProblem",
    "line_brackets",
    "screening_method",
]

logger = logging.getLogger(__name__)

#: ``log(objective / target)`` given to a bistable objective (it never resets) and to one
#: that resets before the release ends (monostable, negative reset time): the root finders'
#: stand-in for an infinite log ratio (:data:`dpfexplore.inverse.engine.roots.LOG_INF`).
_LOG_INF = LOG_INF
#: Classes an objective unit may have (never inverted and no-contact units have no reset).
_RESETTING = (CLASS_BISTABLE, CLASS_METASTABLE, CLASS_MONOSTABLE)


def screening_method(preferred: str, pulse: PulseSpec) -> tuple[str, str]:
    """The reduced model that screens a profile, and why.

    ``"fast"`` only where the packaged fast reset-time model loads and was trained on this pulse
    and horizon (else its rows would all fall back to the full model); ``"release"`` otherwise.
    """
    if preferred != "fast":
        return preferred, f"{preferred} (as the scene asks)"
    from ....solvers.dynamics.fast_reset import in_scene
    from ....solvers.dynamics.reset_model import load_reset_model

    try:
        model = load_reset_model()
    except (OSError, ValueError) as exc:
        return "release", f"release (the fast model is not available: {exc})"
    if not in_scene(model, pulse.profile, pulse.t_end):
        return "release", (
            "release (the pulse or horizon is outside the fast model's trained "
            f"scene: P0 = {model.P0} MPa, tau = {list(model.tau)} s)"
        )
    domain = ", ".join(f"{k} {v[0]:g}-{v[1]:g}" for k, v in model.domain.items() if k in ("H", "t"))
    return "fast", (
        "fast inside its trained domain (" + domain + "), release outside it (the "
        "scene's pulse is the fast model's trained scene)"
    )


@dataclass
class ResetEval:
    """Reset-time outputs of box points under one profile.

    Attributes
    ----------
    z : ndarray of shape (m, 2)
    reset : ndarray of shape (m, N), s
        ``inf`` for a unit still inverted at the horizon, NaN for one never inverted.
    classes : ndarray of int, shape (m, N)
        :data:`dpfexplore.solvers.dynamics.common.CLASS_NAMES` codes.
    final_state : ndarray of int, shape (m,)
    status : ndarray of int8, shape (m,)
    value : ndarray of shape (m,), s
        The scene's objective reset time (NaN where not admissible).
    admissible : ndarray of bool, shape (m,)
    method : str
    """

    z: NDArray
    reset: NDArray
    classes: NDArray
    final_state: NDArray
    status: NDArray
    value: NDArray
    admissible: NDArray
    method: str
    extra: dict = field(default_factory=dict)

    def log_ratio(self, target: float) -> NDArray:
        """``log(value / target)``: finite, ``±`` :data:`_LOG_INF` where it is ``inf`` or <= 0."""
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log(self.value / target)
        out = np.where(np.isposinf(self.value), _LOG_INF, out)
        out = np.where(np.isfinite(self.value) & (self.value <= 0), -_LOG_INF, out)
        return np.where(self.admissible, out, np.nan)

    def unit_log_ratio(self, unit: int, target: float, hold: NDArray) -> NDArray:
        """``log(reset / target)`` of one 1-based ``unit`` (clipped as :meth:`log_ratio`).

        Admissible where the ``hold`` units (0-based) stay inverted and the unit resets or is
        bistable.
        """
        k = unit - 1
        ok = (self.status == st.OK) & np.all(self.classes[:, hold] == CLASS_BISTABLE, axis=1)
        ok &= np.isin(self.classes[:, k], _RESETTING)
        r = self.reset[:, k]
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log(r / target)
        out = np.where(np.isposinf(r), _LOG_INF, out)
        out = np.where(np.isfinite(r) & (r <= 0), -_LOG_INF, out)
        return np.where(ok, out, np.nan)


class ResetProblem(Problem):
    """The pick-and-place scene at its one number of units (module docstring).

    Parameters
    ----------
    spec : SceneSpec
        A ``pickplace`` scene.
    evaluator : SceneEvaluator
    target_index : int
        Result row this problem serves (recorded in the history).
    """

    n_residuals = 1
    #: Its solves through :meth:`evaluate` are grasp-stiffness statics; the reset objective is
    #: recorded by the reset runs.
    records_objective = False

    def __init__(
        self, spec: SceneSpec[PickPlaceSpec], evaluator: SceneEvaluator, target_index: int = 0
    ) -> None:
        self.spec = spec
        self.p: PickPlaceSpec = spec.kind_spec
        self.variables = spec.design_variables(spec.n_units[0])
        self.dim = self.variables.n_variables
        self.evaluator = evaluator
        self.target_index = target_index
        n = self.variables.n_units
        self.hold = np.array([k - 1 for k in self.p.hold_units], dtype=np.int64)
        self.others = np.array(
            [k for k in range(n) if k + 1 not in self.p.hold_units], dtype=np.int64
        )
        self.grasp = int(self.p.grasp_state, 2)

    # ------------------------------------------------------------------ designs and statics

    def designs(self, z: NDArray) -> DesignBatch:
        """The designs of box points ``z`` (shape ``(m, 2)``: height variable, t)."""
        return self.variables.designs(np.atleast_2d(z))

    def design(self, z: NDArray) -> Design:
        """The design of one box point."""
        return self.variables.design(np.asarray(z, dtype=float))

    def requests(self, z: NDArray, *, stiffness: bool) -> tuple[DesignBatch, NDArray, NDArray]:
        """The grasp state, with its stiffness when asked."""
        return self.designs(z), np.array([self.grasp]), np.array([stiffness])

    def finish(self, z: NDArray, batch: DesignBatch, out: dict[str, NDArray]) -> Evaluation:
        """Grasp stiffness (N/mm) where the grasp state exists; the reset residual is not static."""
        ok = out["status"][:, 0] == st.OK
        k = np.where(ok, out["stiffness"][:, 0], np.nan)
        columns = {
            "state": np.full(len(z), self.p.grasp_state),
            "status": out["status"][:, 0],
            "tip_x": out["tip_x"][:, 0],
            "tip_y": out["tip_y"][:, 0],
        }
        return Evaluation(
            z=z, ok=ok, residual=np.full((len(z), 1), np.nan), stiffness=k, columns=columns
        )

    def grasp_stiffness(self, z: NDArray, *, purpose: str) -> NDArray:
        """Tip stiffness (N/mm) of the grasp state at box points (NaN where it does not exist)."""
        return self.evaluate(np.atleast_2d(z), purpose=purpose, stiffness=True).stiffness

    # ------------------------------------------------------------------ dynamics

    def objective_value(
        self, reset: NDArray, classes: NDArray, status: NDArray
    ) -> tuple[NDArray, NDArray]:
        """The objective reset time of each row and whether the row is admissible."""
        ok = (status == st.OK) & np.all(classes[:, self.hold] == CLASS_BISTABLE, axis=1)
        others_cls = classes[:, self.others]
        counted = np.isin(others_cls, _RESETTING)
        if self.p.reset_unit == "last":
            values = np.where(counted, reset[:, self.others], -np.inf)
            value = np.max(values, axis=1)
            ok &= np.any(counted, axis=1)
        else:
            k = int(self.p.reset_unit) - 1
            value = reset[:, k].copy()
            ok &= np.isin(classes[:, k], _RESETTING)
        return np.where(ok, value, np.nan), ok

    def objective_unit(self, reset: NDArray, classes: NDArray) -> int:
        """1-based unit whose reset time is the objective (of one row's outputs)."""
        if self.p.reset_unit != "last":
            return int(self.p.reset_unit)
        counted = [k for k in self.others if classes[k] in _RESETTING]
        return int(max(counted, key=lambda k: reset[k]) + 1) if counted else 0

    def resets(
        self,
        z: NDArray,
        *,
        purpose: str,
        method: str,
        pulse: PulseSpec | None = None,
        atol: float | None = None,
        objective_target: float | None = None,
        profile_index: int = 1,
    ) -> ResetEval:
        """Reset times of box points under the scene's pulse (or ``pulse``), recorded.

        ``objective_target``: record ``|value / target - 1|`` as the history's objective for
        full-model rows (screening rows record none: they are not exact).
        """
        z = np.atleast_2d(np.asarray(z, dtype=float))
        pulse = self.p.pulse if pulse is None else pulse
        batch = self.designs(z)
        if method == "fast":
            out, methods = self._fast_or_release(batch, pulse)
        else:
            out = self.evaluator.reset_times(
                batch, pulse.profile, t_end=pulse.t_end, method=method, atol=atol
            )
            methods = np.full(len(z), method)
        n = self.variables.n_units
        reset, classes = out["reset_time"][:, :n], out["unit_class"][:, :n].astype(np.int64)
        value, ok = self.objective_value(reset, classes, out["status"])
        ev = ResetEval(
            z=z,
            reset=reset,
            classes=classes,
            final_state=out["final_state"],
            status=out["status"],
            value=value,
            admissible=ok,
            method=method,
        )
        ev.extra["methods"] = methods
        self._record(batch, ev, purpose, objective_target, profile_index)
        return ev

    def _fast_or_release(
        self, batch: DesignBatch, pulse: PulseSpec
    ) -> tuple[dict[str, NDArray], NDArray]:
        """The fast model on the rows inside its trained domain, ``release`` on the others.

        (Outside its domain the fast model would run the full model instead: far slower than
        the release model, which is all a screening needs.)
        """
        from ....solvers.dynamics.fast_reset import in_domain
        from ....solvers.dynamics.reset_model import load_reset_model

        inside = in_domain(load_reset_model(), batch)
        methods = np.where(inside, "fast", "release")
        parts = {}
        for name in ("fast", "release"):
            rows = np.flatnonzero(methods == name)
            if rows.size:
                parts[name] = (
                    rows,
                    self.evaluator.reset_times(
                        batch.take(rows), pulse.profile, t_end=pulse.t_end, method=name
                    ),
                )
        out: dict[str, NDArray] = {}
        for key in ("status", "final_state", "reset_time", "unit_class"):
            first = next(iter(parts.values()))[1][key]
            out[key] = np.empty((len(batch), *first.shape[1:]), dtype=first.dtype)
            for rows, part in parts.values():
                out[key][rows] = part[key]
        if "fast" in parts:
            rows, part = parts["fast"]
            fell_back = part["fallback"]
            methods[rows[fell_back]] = "fast (fallback: rodas4)"
        return out, methods

    def _record(
        self,
        batch: DesignBatch,
        ev: ResetEval,
        purpose: str,
        target: float | None,
        profile_index: int,
    ) -> None:
        exact = ev.method not in ("fast", "release")
        objective = np.full(len(ev.z), np.nan)
        if target is not None and exact:  # screening rows are never the answer
            with np.errstate(invalid="ignore"):
                objective = np.where(ev.admissible, np.abs(ev.value / target - 1.0), np.nan)
        columns = {f"reset_{k + 1}": ev.reset[:, k] for k in range(ev.reset.shape[1])}
        columns.update(
            {f"class_{k + 1}": ev.classes[:, k].astype(np.int8) for k in range(ev.classes.shape[1])}
        )
        self.evaluator.record(
            batch,
            target=self.target_index,
            purpose=purpose,
            method=ev.extra.get("methods", ev.method),
            profile=profile_index,
            objective=objective,
            reset_objective=ev.value,
            admissible=ev.admissible,
            status=ev.status,
            final_state=ev.final_state,
            **columns,
        )

    def simulate(
        self,
        design: Design,
        *,
        pulse: PulseSpec | None = None,
        atol: float,
        kind: str = "verifications",
    ):
        """One full-model run to the horizon (no early stop): the verification of a design."""
        pulse = self.p.pulse if pulse is None else pulse
        return self.evaluator.simulate(
            design, pulse.profile, t_end=pulse.t_end, atol=atol, kind=kind
        )


@dataclass(frozen=True)
class Bracket:
    """A sign change of ``log(objective / target)`` between two box points of one line."""

    z_lo: tuple[float, float]
    z_hi: tuple[float, float]
    f_lo: float
    f_hi: float
    in_fitted_range: bool
    stiffness: float


def line_brackets(
    ev: ResetEval, shape: tuple[int, int], target: float, *, fitted: NDArray, stiffness: NDArray
) -> list[Bracket]:
    """Sign changes of ``log(objective / target)`` between neighbours along each line of a grid.

    Parameters
    ----------
    ev : ResetEval
        Screening of a grid whose rows are ``shape = (lines, points)`` in C order (points vary
        fastest, along the height variable).
    target : float, s
    fitted : ndarray of bool, shape (lines * points,)
        Rows inside the fitted range.
    stiffness : ndarray of shape (lines * points,), N/mm
        Grasp stiffness of each row (the brackets' ranking).

    Returns
    -------
    list of Bracket
        Both ends admissible, one below the target and one at or above it.
    """
    f = ev.log_ratio(target).reshape(shape)
    out = []
    for j in range(shape[0]):
        for i in range(shape[1] - 1):
            a, b = f[j, i], f[j, i + 1]
            if not (np.isfinite(a) and np.isfinite(b)) or (a < 0) == (b < 0):
                continue
            r0, r1 = j * shape[1] + i, j * shape[1] + i + 1
            out.append(
                Bracket(
                    tuple(ev.z[r0]),
                    tuple(ev.z[r1]),
                    float(a),
                    float(b),
                    bool(fitted[r0] and fitted[r1]),
                    float(np.nanmean([stiffness[r0], stiffness[r1]])),
                )
            )
    return out
