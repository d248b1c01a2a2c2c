"""Polish a design with the exact model until its outputs meet a target.

:func:`refine` moves a design, inside the box and constraints of a
:class:`~dpfexplore.model.variables.DesignVariables`, until the outputs of one stable state
(the tip by default) equal a target to a tolerance (1e-6 mm). It is bounded nonlinear least
squares on the variables ``z ∈ [0, 1]^m`` of that exact reparametrisation
(:func:`scipy.optimize.least_squares`: dogbox, then trust-region reflective from the same start
if dogbox stops short; see :data:`_STAGES`), with residual ``(outputs(z) - target) / scales``
and Jacobian ``∂outputs/∂θ · ∂θ/∂z``: the model's design sensitivities chained with
:meth:`DesignVariables.jacobian`. Every design it evaluates satisfies the constraints exactly
(heights ordered, ``U_L`` / ``U_sep`` shared, ties), so no penalty is needed. The problems are
underdetermined (two tip coordinates, up to 3N + 2 variables): Gauss-Newton steps of minimum
norm move the design as little as the target allows.

States that vanish
    A state exists only on part of the design space: past a fold the requested inversion
    vector collapses into another state. A trial design whose state collapses (or whose solve
    fails) gets a large residual, so the trust region rejects the step and shrinks; the search
    continues on the side where the state exists. A refinement that ends short of the target
    after meeting collapses reports ``"collapsed"`` (the target lies beyond the state's fold from
    this start) with the best design it found where the state exists; one that ends short
    without meeting any reports ``"not_met"`` (bounds or constraints stop it, or a local
    minimum of the distance). A start whose state does not exist under the constraints (the
    projection of a dataset design onto them can leave its fold) reports ``"collapsed"`` at once.

Sensitivities
    :func:`_model_outputs` is the one place that asks the model for outputs and their exact
    derivatives with respect to the design parameters ``θ = (H_1..H_N, U_L_1..U_L_N,
    U_sep_1..U_sep_N, t, t_lim, E)`` (implicit-function sensitivities,
    ``solve_batch(..., sensitivities=True)``): one solve gives the residual and the Jacobian.
    :func:`_central_differences` gives the same from ``2 (3N + 3)`` perturbed solves (one batch
    call); it is the baseline of ``dpfexplore bench lookup`` (``sensitivities="central"``), and
    the fallback at a point where the exact derivatives are undefined (Hessian not positive
    definite at the returned shape).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model import status as st
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS
from ..model.variables import HEIGHT_ORDERS, DesignVariables
from ..numerics.differences import central_differences
from ..numerics.local import GOAL_MET, NO_START, Stage, least_squares_in_box
from ..solvers.sensitivities import OUTPUTS, batch_columns
from ..solvers.statics import parse_state, solve_batch, state_string
from ..sweep.space import DesignSpace

__all__ = [
    "CONSTRAINT_KEYS",
    "REFINABLE_COLUMNS",
    "Refinement",
    "parse_constraints",
    "refine",
    "variables_for",
]

#: Outputs the model has design sensitivities for (the columns a refinement can target).
REFINABLE_COLUMNS = tuple(OUTPUTS)
#: Keys of a constraints mapping (:func:`variables_for`) and of ``--constraints KEY=VALUE``.
CONSTRAINT_KEYS = (
    "heights",
    "ordered_units",
    "tied",
    "shared_U_L",
    "shared_U_sep",
    "H",
    "U_L",
    "U_sep",
    "t",
    "t_lim",
)
_BOUNDED = ("H", "U_L", "U_sep", "t", "t_lim")
#: Relative step of the central differences (per parameter, times max(|θ|, 1)): the solver's
#: outputs are accurate to ~1e-13 mm, so the rounding error is ~1e-13 / 1e-5 and the truncation
#: error ~1e-10: derivatives to ~1e-8 relative, ample for Gauss-Newton.
_FD_STEP = 1e-5
#: Refinement stops once the error is below this fraction of the tolerance: the reported design
#: is re-solved before it is shown, and the margin keeps it inside the tolerance.
_MARGIN = 0.1


# ----------------------------------------------------------------------------- variables


def variables_for(
    space: DesignSpace, design: Design, constraints: Mapping | None = None
) -> DesignVariables:
    """The variables a refinement of ``design`` moves in: the job's box and the user's constraints.

    Parameters
    ----------
    space : DesignSpace
        The job's design space (bounds of ``H``, ``U_L``, ``U_sep``, ``t``, ``t_lim``; height
        order; shared ``U_L`` / ``U_sep``).
    design : Design
        Sets ``N`` and the fixed ``E``, ``nu``, ``r_b``, ``t_ch`` (a job that samples ``E`` keeps
        each design's own).
    constraints : mapping, optional
        Keys of :data:`CONSTRAINT_KEYS`: ``heights`` ("free", "ascending", "descending"),
        ``ordered_units`` (1-based units the order covers), ``tied`` (groups of units of equal
        height), ``shared_U_L`` / ``shared_U_sep`` (bool), and bounds ``H``, ``U_L``, ``U_sep``,
        ``t``, ``t_lim`` as a number (fixed) or ``[low, high]``, intersected with the job's.

    Raises
    ------
    ValueError
        Naming the key, for an unknown key, a constraint that contradicts the job's (the job's
        heights are ascending and the user asks descending; the job shares ``U_L`` and the user
        asks per-unit) or bounds outside the job's box.
    """
    constraints = dict(constraints or {})
    for key in constraints:
        if key not in CONSTRAINT_KEYS:
            raise ValueError(
                f"constraints: unknown key {key!r}; known: {', '.join(CONSTRAINT_KEYS)}"
            )
    values: dict = {}
    for name in _BOUNDED:
        var = space.variable(name)
        low, high = var.low, var.high
        if name in constraints:
            user = constraints[name]
            u_low, u_high = (float(user), float(user)) if np.ndim(user) == 0 else map(float, user)
            low, high = max(low, u_low), min(high, u_high)
            if low > high:
                raise ValueError(
                    f"constraints: {name} = {user!r} lies outside the job's box "
                    f"[{var.low}, {var.high}]"
                )
        values[name] = low if low == high else (low, high)
    heights = constraints.get("heights", space.heights)
    if heights not in HEIGHT_ORDERS:
        raise ValueError(f"constraints: heights = {heights!r}; choose one of {HEIGHT_ORDERS}")
    if space.heights != "free" and heights != space.heights:
        raise ValueError(
            f"constraints: heights = {heights!r} contradicts the job's {space.heights!r} heights"
        )
    if space.heights != "free" and constraints.get("ordered_units") is not None:
        raise ValueError(
            f"constraints: ordered_units = {constraints['ordered_units']!r}: the job orders "
            "every unit already"
        )
    shared = {}
    for name, job_shares in (("U_L", space.equal_U_L), ("U_sep", space.equal_U_sep)):
        wanted = constraints.get(f"shared_{name}", job_shares)
        if job_shares and not wanted:
            raise ValueError(
                f"constraints: shared_{name} = false contradicts the job's shared {name}"
            )
        shared[f"shared_{name}"] = bool(wanted)
    return DesignVariables(
        n_units=design.n_units,
        **values,
        heights=heights,
        ordered_units=constraints.get("ordered_units"),
        tied=constraints.get("tied", ()),
        **shared,
        E=design.E,
        nu=design.nu,
        r_b=design.r_b,
        t_ch=design.t_ch,
        constants=design.constants,
    )


def parse_constraints(items: Sequence[str]) -> dict:
    """``["heights=descending", "shared=U_L,U_sep", "t=0.6:0.9", "tied=5,6"]`` as a mapping.

    Grammar (one ``KEY=VALUE`` per item): ``heights=free|ascending|descending``;
    ``ordered_units=1-4`` or ``1,2,3,4``; ``tied=5,6`` (groups separated by ``;``, or the key
    repeated); ``shared=U_L,U_sep``; bounds ``H|U_L|U_sep|t|t_lim=LOW:HIGH`` or ``=VALUE``.

    Raises
    ------
    ValueError
        Naming the item, for any other form.
    """
    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not value:
            raise ValueError(f"constraint {item!r}: write KEY=VALUE, e.g. heights=descending")
        try:
            if key == "heights":
                out["heights"] = value
            elif key == "ordered_units":
                out["ordered_units"] = _units(value)
            elif key == "tied":
                out.setdefault("tied", []).extend(_units(g) for g in value.split(";") if g)
            elif key == "shared":
                for name in value.split(","):
                    if name.strip() not in ("U_L", "U_sep"):
                        raise ValueError
                    out[f"shared_{name.strip()}"] = True
            elif key in _BOUNDED:
                low, colon, high = value.partition(":")
                out[key] = [float(low), float(high)] if colon else float(low)
            else:
                raise ValueError
        except ValueError:
            raise ValueError(
                f"constraint {item!r}: not understood; use heights=free|ascending|descending, "
                "ordered_units=1-4, tied=5,6, shared=U_L,U_sep, or H|U_L|U_sep|t|t_lim=LOW:HIGH"
            ) from None
    return out


def _units(text: str) -> list[int]:
    text = text.strip()
    if "-" in text:
        low, high = (int(v) for v in text.split("-"))
        return list(range(low, high + 1))
    return [int(v) for v in text.split(",")]


# ----------------------------------------------------------------------------- the model


def _theta(batch: DesignBatch) -> NDArray:
    """Parameters of a one-design batch in sensitivity order (``H..``, ``U_L..``, ..., ``E``)."""
    n = int(batch.n_units[0])
    shared = [batch.t[0], batch.t_lim[0], batch.E[0]]
    return np.concatenate([batch.H[0, :n], batch.U_L[0, :n], batch.U_sep[0, :n], shared])


def _batch_of(theta: NDArray, like: DesignBatch) -> DesignBatch:
    """Designs with the parameters ``theta`` (rows, sensitivity order), the rest from ``like``."""
    m, n = theta.shape[0], int(like.n_units[0])
    pad = np.full((m, MAX_UNITS - n), np.nan)
    return DesignBatch(
        n_units=np.full(m, n),
        H=np.hstack([theta[:, :n], pad]),
        U_L=np.hstack([theta[:, n : 2 * n], pad]),
        U_sep=np.hstack([theta[:, 2 * n : 3 * n], pad]),
        t=theta[:, 3 * n],
        t_lim=theta[:, 3 * n + 1],
        E=theta[:, 3 * n + 2],
        nu=like.nu[0],
        r_b=like.r_b[0],
        t_ch=like.t_ch[0],
        constants=like.constants,
    )


def _model_outputs(
    batch: DesignBatch, state: int, columns: Sequence[str], *, derivatives: bool
) -> tuple[NDArray, NDArray | None, int]:
    """Outputs of one design's state and, if asked, their derivatives with respect to ``θ``.

    Stiffness is always computed: it needs the Hessian factored at the returned shape, which
    fails next to a fold; the verification of a reported design asks for it, so a design
    accepted here passes there.

    Returns
    -------
    values : ndarray of shape (d,)
        ``columns`` of the state (NaN unless the status is ok).
    jac : ndarray of shape (d, 3N + 3) or None
        ``∂values/∂θ`` (None unless asked and the state exists).
    status : int
        :mod:`~dpfexplore.model.status` code of the state at the design.
    """
    cols = solve_batch(batch, [state], stiffness=True, min_eig=False, sensitivities=derivatives)
    values = np.array([cols[c][0] for c in columns])
    status = int(cols["status"][0])
    if not derivatives or status != st.OK:
        return values, None, status
    pick = batch_columns(int(batch.n_units[0]))
    jac = np.stack([cols[f"d_{c}"][0, pick] for c in columns])
    if not np.all(np.isfinite(jac)):
        return _central_differences(batch, state, columns, derivatives=True)
    return values, jac, status


def _central_differences(
    batch: DesignBatch, state: int, columns: Sequence[str], *, derivatives: bool
) -> tuple[NDArray, NDArray | None, int]:
    """:func:`_model_outputs` with derivatives by central differences of the solver.

    Stiffness is always computed, for the reason given there.
    """
    if not derivatives:
        cols = solve_batch(batch, [state], stiffness=True, min_eig=False)
        return np.array([cols[c][0] for c in columns]), None, int(cols["status"][0])
    theta = _theta(batch)

    def outputs(rows: NDArray) -> NDArray:
        cols = solve_batch(
            _batch_of(rows, batch), [state] * len(rows), stiffness=True, min_eig=False
        )
        values = np.stack([cols[c] for c in columns], axis=1)
        return np.where((cols["status"] == st.OK)[:, None], values, np.nan)

    centre = outputs(theta[None, :])[0]
    if not np.all(np.isfinite(centre)):
        cols = solve_batch(batch, [state], stiffness=True, min_eig=False)
        return np.array([cols[c][0] for c in columns]), None, int(cols["status"][0])
    # next to a fold one side of a difference may collapse: the routine takes the other side
    jac = central_differences(
        outputs, theta, centre, step=_FD_STEP * np.maximum(np.abs(theta), 1.0)
    )
    return centre, jac, int(st.OK)


#: How :func:`refine` gets the model's derivatives.
SENSITIVITIES = {"exact": _model_outputs, "central": _central_differences}


# ----------------------------------------------------------------------------- refinement


@dataclass(frozen=True)
class Refinement:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    design : Design
        The refined design (the best one found where the state exists; the projected start if
        the state does not exist there).
    state : str
        The state refined, unit 1 first.
    status : {"ok", "not_met", "collapsed"}
        Target met to the tolerance; not met (bounds, constraints or a local minimum); the state
        collapsed (at the start, or on the way with the target not met).
    error : float
        Scaled Euclidean distance of the outputs from the target (mm for the tip) at ``design``;
        NaN if the state does not exist there.
    values : ndarray of shape (d,)
        The outputs at ``design``.
    evaluations : int
        Designs solved for values (with exact sensitivities, each solve also gives the
        derivatives).
    jacobians : int
        Jacobians used (with exact sensitivities, those of accepted steps come with their
        values; otherwise each is one batch of perturbed solves).
    collapses : int
        Trial designs whose state collapsed or whose solve failed.
    seconds : float
        Wall time.
    message : str
        What stopped it.
    """

    design: Design
    state: str
    status: str
    error: float
    values: NDArray
    evaluations: int
    jacobians: int
    collapses: int
    seconds: float
    message: str


#: The least-squares runs of a refinement, each from the start, until one meets the target:
#: dogbox (a dogleg in the box ∩ trust region, minimum-norm Gauss-Newton steps by ``lstsq``)
#: converges like trf on these small underdetermined problems (median 3 evaluations from a
#: dataset neighbour) at a fifth of trf's cost per iteration, but its longer steps more often
#: land past a fold, after which it creeps along it; so it gets 14 evaluations after the start
#: (about five times what it needs when it converges), and trf with LSMR subproblems, whose
#: path differs, takes the rest of the budget from the same start. trf's exact (SVD)
#: subproblem is not used: its bound scaling damps every step of these zero-residual problems,
#: converging only linearly (about 0.65 per iteration).
_STAGES = (Stage("dogbox", "exact", 14), Stage("trf", "lsmr"))


class _Problem:
    """Residual and Jacobian in ``z`` of one refinement (the model's outputs, scaled)."""

    def __init__(self, variables, state, target, scales, columns, model) -> None:
        self.variables, self.state, self.columns = variables, state, columns
        self.target, self.scales = target, scales
        self.model = model
        # The model's sensitivities cost less than a second solve: take them with every value,
        # so that an accepted step has its Jacobian already.
        self.together = model is _model_outputs
        self._jac_at: tuple[NDArray, NDArray] | None = None

    def residual(self, z: NDArray) -> tuple[NDArray | None, NDArray]:
        """Scaled residual at ``z`` (None where the state collapses) and the outputs."""
        batch = self.variables.designs(z[None, :])
        values, jac, status = self.model(batch, self.state, self.columns, derivatives=self.together)
        if status != st.OK:
            return None, values
        if jac is not None:
            self._jac_at = (z, jac)
        return (values - self.target) / self.scales, values

    def jacobian(self, z: NDArray) -> NDArray:
        if self._jac_at is not None and np.array_equal(self._jac_at[0], z):
            jac = self._jac_at[1]
        else:
            batch = self.variables.designs(z[None, :])
            _, jac, _ = self.model(batch, self.state, self.columns, derivatives=True)
        if jac is None:  # only accepted points get here, where the state exists
            return np.zeros((len(self.columns), self.variables.n_variables))
        return (jac / self.scales[:, None]) @ self.variables.jacobian(z[None, :])[0]


def _project(design: Design, variables: DesignVariables) -> DesignBatch:
    """``design`` with shared ``U_L`` / ``U_sep`` and tied heights set to their means."""
    batch = DesignBatch.from_designs([design])
    n = design.n_units
    H, U_L, U_sep = batch.H.copy(), batch.U_L.copy(), batch.U_sep.copy()
    if variables.shared_U_L:
        U_L[0, :n] = U_L[0, :n].mean()
    if variables.shared_U_sep:
        U_sep[0, :n] = U_sep[0, :n].mean()
    for group in variables.tied:
        units = [int(u) - 1 for u in group]
        H[0, units] = H[0, units].mean()
    return batch.with_arrays(H=H, U_L=U_L, U_sep=U_sep)


def refine(
    design: Design,
    state: str | int,
    target: ArrayLike,
    *,
    variables: DesignVariables,
    columns: Sequence[str] = ("tip_x", "tip_y"),
    scales: ArrayLike | None = None,
    tol: float = 1e-6,
    max_evaluations: int = 60,
    sensitivities: str = "exact",
) -> Refinement:
    """Move ``design`` inside ``variables`` until the outputs of ``state`` meet ``target``.

    Parameters
    ----------
    design : Design
        Starting design; projected onto the constraints (shared values and tied heights take
        their mean, heights out of order or bounds are clipped) if it does not satisfy them.
    state : str or int
        Stable state whose outputs are matched (``"11111"``).
    target : array_like of shape (d,)
        Wanted values of ``columns`` (mm for the tip).
    variables : DesignVariables
        Bounds and constraints (:func:`variables_for`).
    columns : sequence of str
        Outputs to match, from :data:`REFINABLE_COLUMNS`.
    scales : array_like of shape (d,), optional
        Scale of each column (default 1 in its unit); the error is the Euclidean norm of
        ``(values - target) / scales``.
    tol : float
        Error to reach (1e-6: a micrometre of tip position).
    max_evaluations : int
        Cap on model evaluations for values.
    sensitivities : {"exact", "central"}
        The model's implicit-function derivatives, or central differences of the solver (the
        benchmark's baseline).

    Raises
    ------
    ValueError
        A column without sensitivities, a target or scales of the wrong length, ``tol <= 0``,
        or a design of another ``N`` than ``variables``.
    """
    columns = tuple(columns)
    for name in columns:
        if name not in REFINABLE_COLUMNS:
            raise ValueError(
                f"column {name!r}: cannot be refined (no model sensitivity); refinable: "
                f"{', '.join(REFINABLE_COLUMNS)}"
            )
    target = np.asarray(target, dtype=float).reshape(-1)
    if target.shape != (len(columns),) or not np.all(np.isfinite(target)):
        raise ValueError(f"target = {target.tolist()!r}: need {len(columns)} finite values")
    scales = np.ones(len(columns)) if scales is None else np.asarray(scales, float).reshape(-1)
    if scales.shape != (len(columns),) or not np.all(scales > 0):
        raise ValueError(f"scales = {scales.tolist()!r}: need {len(columns)} values > 0")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol = {tol!r}: must be finite and > 0")
    if sensitivities not in SENSITIVITIES:
        raise ValueError(
            f"sensitivities = {sensitivities!r}: choose one of {', '.join(SENSITIVITIES)}"
        )
    if design.n_units != variables.n_units:
        raise ValueError(f"design has {design.n_units} units, the variables {variables.n_units}")
    state_int = parse_state(state, design.n_units)
    bits = state_string(state_int, design.n_units)
    start = time.perf_counter()
    problem = _Problem(variables, state_int, target, scales, columns, SENSITIVITIES[sensitivities])
    z0 = variables.encode(_project(design, variables))[0][0]
    run = least_squares_in_box(
        problem.residual,
        z0,
        jac=problem.jacobian,
        max_nfev=max(int(max_evaluations), 1),
        goal=(_MARGIN * tol) ** 2,
        stages=_STAGES,
        ftol=1e-12,
        xtol=1e-12,
        gtol=1e-12,
    )
    found = run.status != NO_START
    error = math.sqrt(run.objective) if found else float("nan")
    if run.status == GOAL_MET:
        status = "ok"
        message = "the start meets the target" if run.nfev == 1 else f"met to {error:.2g}"
    elif not found:
        status, message = "collapsed", f"state {bits} does not exist at the (projected) start"
    elif variables.n_variables == 0:
        status, message = "not_met", "no free variables"
    elif run.failures:
        status = "collapsed"
        message = (
            f"state {bits} collapsed at {run.failures} trial designs; stopped at "
            f"{error:.3g} ({run.message})"
        )
    else:
        status, message = "not_met", f"stopped at {error:.3g}: {run.message}"
    return Refinement(
        design=variables.design(run.x),
        state=bits,
        status=status,
        error=error,
        values=run.info if found else np.full(len(columns), np.nan),
        evaluations=run.nfev,
        jacobians=run.njev,
        collapses=run.failures,
        seconds=time.perf_counter() - start,
        message=message,
    )
