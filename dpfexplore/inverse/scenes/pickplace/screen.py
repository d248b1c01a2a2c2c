"""The pick-and-place scene's screening grid, its reachable range and the verification run.

The grid has ``grid.t`` lines of constant ``t`` with ``grid.H`` heights each (the box variables
of :class:`~dpfexplore.inverse.scenes.pickplace.problem.ResetProblem`). The first stage screens the
rows inside the fast reset model's trained domain with it (where the scene's pulse is its trained
scene; the whole fitted range lies inside that domain) and solves the grasp stiffness of every
row (statics, one batch); the other rows are screened by the release model only when a result
needs them (a target with no bracket in the first stage, the two-unit and difference objectives,
the reachable range). Screening values only place brackets; every reported value comes from
:func:`check_design`, the full model run alone to the horizon.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np
from numpy.typing import NDArray

from ....model.design import Design
from ....solvers.dynamics.common import CLASS_METASTABLE
from ...evaluation import SceneEvaluator
from ...spec import SceneSpec
from .problem import ResetEval, ResetProblem, screening_method
from .spec import PickPlaceSpec, PulseSpec

__all__ = [
    "DesignCheck",
    "Screen",
    "check_design",
    "reachable_range",
    "screen_pickplace",
    "second_screen",
]


class DesignCheck(TypedDict):
    """A design run alone in the full model to the horizon (:func:`check_design`).

    ``reset_times`` of every unit (s; ``inf`` never reset, NaN never inverted), their
    ``classes``, the ``final_state`` and ``status`` of the run, ``value`` the scene's objective
    reset time (s), ``admissible`` (hold units bistable, objective defined), ``objective_unit``
    (1-based; 0 none), the run's ``atol`` (mm) and ``t_end`` (s).
    """

    reset_times: NDArray
    classes: list[str | None]
    final_state: str
    status: str
    value: float
    admissible: bool
    objective_unit: int
    atol: float
    t_end: float


@dataclass
class Screen:
    """The screening grid of a pick-and-place scene run (shared by its targets).

    Rows not screened yet have ``admissible`` False and NaN values (``screened`` False); the
    first stage screens the rows where the fast model is trained (the fitted range lies inside
    them), ``screen_pickplace(..., complete=True)`` the rest with the release model when a result
    needs them.
    """

    problem: ResetProblem
    shape: tuple[int, int]
    ev: ResetEval
    screened: NDArray
    stiffness: NDArray
    fitted: NDArray
    method: str
    note: str
    wall_s: float
    ranges: dict | None = None
    ranges_wall_s: float = 0.0
    second: ResetEval | None = None
    second_method: str = ""

    @property
    def complete(self) -> bool:
        """Every grid row screened."""
        return bool(np.all(self.screened))


def _grid(spec: SceneSpec[PickPlaceSpec]) -> tuple[NDArray, tuple[int, int]]:
    p = spec.kind_spec
    zt = np.linspace(0.0, 1.0, p.grid_t)
    zh = np.linspace(0.0, 1.0, p.grid_H)
    z = np.column_stack([np.tile(zh, p.grid_t), np.repeat(zt, p.grid_H)])
    return z, (p.grid_t, p.grid_H)


def _empty_eval(z: NDArray, n: int) -> ResetEval:
    m = len(z)
    return ResetEval(
        z=z,
        reset=np.full((m, n), np.nan),
        classes=np.full((m, n), -1, np.int64),
        final_state=np.full(m, -1, np.int64),
        status=np.zeros(m, np.int8),
        value=np.full(m, np.nan),
        admissible=np.zeros(m, bool),
        method="",
        extra={"methods": np.full(m, "", dtype=object)},
    )


def _fill(full: ResetEval, rows: NDArray, part: ResetEval) -> None:
    for name in ("reset", "classes", "final_state", "status", "value", "admissible"):
        getattr(full, name)[rows] = getattr(part, name)
    full.extra["methods"][rows] = part.extra.get("methods", part.method)


def screen_pickplace(
    spec: SceneSpec[PickPlaceSpec], evaluator: SceneEvaluator, *, complete: bool = False
) -> Screen:
    """The screening of a scene (cached on the evaluator: computed once per run).

    The first call screens the grid rows inside the fast model's trained domain (all rows when
    the scene screens with another model) and solves the grasp stiffness of every row (statics,
    one batch); ``complete=True`` also screens the remaining rows (release model).
    """
    screen = evaluator.cache.get("pickplace-screen")
    if screen is None:
        started = time.perf_counter()
        p = spec.kind_spec
        problem = ResetProblem(spec, evaluator, target_index=-1)
        z, shape = _grid(spec)
        method, note = screening_method(p.screening, p.pulse)
        batch = problem.designs(z)
        if method == "fast":
            from ....solvers.dynamics.fast_reset import in_domain
            from ....solvers.dynamics.reset_model import load_reset_model

            first = in_domain(load_reset_model(), batch)
        else:
            first = np.ones(len(z), dtype=bool)
        ev = _empty_eval(z, problem.variables.n_units)
        rows = np.flatnonzero(first)
        if rows.size:
            _fill(ev, rows, problem.resets(z[rows], purpose="screening", method=method))
        ev.method = method
        stiffness = problem.grasp_stiffness(z, purpose="screening")
        screen = Screen(
            problem, shape, ev, first.copy(), stiffness, batch.in_fitted_range(), method, note, 0.0
        )
        screen.wall_s = time.perf_counter() - started
        evaluator.cache["pickplace-screen"] = screen
    if complete and not screen.complete:
        started = time.perf_counter()
        rows = np.flatnonzero(~screen.screened)
        part = screen.problem.resets(screen.ev.z[rows], purpose="screening", method="release")
        _fill(screen.ev, rows, part)
        screen.screened[:] = True
        if screen.method == "fast":
            screen.note += f"; the {rows.size} rows outside it by the release model"
        screen.wall_s += time.perf_counter() - started
    return screen


def second_screen(spec: SceneSpec[PickPlaceSpec], evaluator: SceneEvaluator) -> Screen:
    """The complete screening with the difference objective's second profile screened too."""
    screen = screen_pickplace(spec, evaluator, complete=True)
    if screen.second is None:
        started = time.perf_counter()
        p = spec.kind_spec
        method, _ = screening_method(p.screening, p.difference.pulse)
        screen.second = screen.problem.resets(
            screen.ev.z,
            purpose="screening",
            method=method,
            pulse=p.difference.pulse,
            profile_index=2,
        )
        screen.second_method = method
        screen.wall_s += time.perf_counter() - started
    return screen


def reachable_range(spec: SceneSpec[PickPlaceSpec], evaluator: SceneEvaluator) -> dict[str, Any]:
    """The range of reset times over the whole box (completes the screening; cached)."""
    screen = screen_pickplace(spec, evaluator, complete=True)
    if screen.ranges is None:
        started = time.perf_counter()
        screen.ranges = _reachable_range(spec, screen, evaluator)
        screen.ranges_wall_s = time.perf_counter() - started
        screen.ranges["wall_s"] = screen.wall_s + screen.ranges_wall_s
    return screen.ranges


def check_design(
    problem: ResetProblem, design: Design, *, pulse: PulseSpec | None = None, atol: float
) -> DesignCheck:
    """Full-model run of a design to the horizon at ``atol``: reset times, classes, objective."""
    from ....solvers.dynamics.common import CLASS_NAMES

    run = problem.simulate(design, pulse=pulse, atol=atol)
    codes = {name: code for code, name in CLASS_NAMES.items()}
    classes = np.array([[codes[c] for c in run.unit_class]], dtype=np.int64)
    reset = run.reset_time[None, :]
    value, ok = problem.objective_value(reset, classes, np.array([int(run.status)]))
    return {
        "reset_times": run.reset_time.copy(),
        "classes": list(run.unit_class),
        "final_state": run.final_state,
        "status": run.status.label,
        "value": float(value[0]),
        "admissible": bool(ok[0]),
        "objective_unit": problem.objective_unit(run.reset_time, classes[0]),
        "atol": atol,
        "t_end": run.t_end,
    }


def _reachable_range(
    spec: SceneSpec[PickPlaceSpec], screen: Screen, evaluator: SceneEvaluator
) -> dict[str, Any]:
    """Range of the objective reset over admissible, metastable-objective screening designs."""
    ev, p = screen.ev, spec.kind_spec
    problem = screen.problem
    n = ev.reset.shape[1]
    rows = np.arange(len(ev.z))
    units = np.array(
        [
            problem.objective_unit(ev.reset[i], ev.classes[i]) if ev.admissible[i] else 0
            for i in rows
        ]
    )
    meta = ev.admissible & np.isfinite(ev.value) & (units > 0)
    meta &= np.array(
        [units[i] > 0 and ev.classes[i, units[i] - 1] == CLASS_METASTABLE for i in rows]
    )
    out: dict = {
        "method": screen.method,
        "grid": {"t": p.grid_t, "H": p.grid_H},
        "designs": len(ev.z),
        "admissible": int(ev.admissible.sum()),
        "metastable": int(meta.sum()),
        "n_units": n,
    }
    for key, mask in (("all", meta), ("fitted_range", meta & screen.fitted)):
        if not mask.any():
            out[key] = None
            continue
        values = np.where(mask, ev.value, np.nan)
        lo, hi = int(np.nanargmin(values)), int(np.nanargmax(values))
        entry = {"min_s": float(values[lo]), "max_s": float(values[hi])}
        for name, i in (("min", lo), ("max", hi)):
            design = problem.design(ev.z[i])
            check = check_design(problem, design, atol=p.search_atol)
            entry[f"{name}_design"] = {"H": list(design.H), "t": design.t}
            entry[f"{name}_full_model_s"] = check["value"]
        out[key] = entry
    out["supremum_s"] = p.pulse.horizon
    out["note"] = (
        "Reset times of admissible designs (hold units bistable, objective unit metastable) on the "
        "screening grid; the extremes re-simulated in the full model. Every time between the "
        "smallest and the horizon is reachable: along a line of t the reset time is continuous "
        "and diverges at the bistable edge, so the supremum is the horizon "
        f"({p.pulse.horizon:g} s after the release), not the grid's largest value."
    )
    return out
