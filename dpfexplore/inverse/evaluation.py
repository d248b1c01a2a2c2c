"""The exact evaluator of inverse design: every model solve of a scene goes through here.

:class:`SceneEvaluator` wraps :func:`dpfexplore.solvers.statics.solve_batch` (and the dynamics and
snap-pressure checks of final candidates), counts each kind of evaluation so that a user sees
what was computed, and records every evaluated design with its outputs for the history. It runs
small batches (a refinement step, a finite-difference stencil) on one Numba thread: waking the
thread pool costs more than the few designs it would share, and far more on a loaded machine.

Kinds of evaluation (:data:`EVALUATION_KINDS`)
    ``designs``       designs evaluated by the exact model (any purpose; what the benchmarks
                      compare)
    ``state_solves``  (design, state) equilibria solved
    ``stiffness``     of those, the ones whose tip stiffness was also computed
    ``derivative``    designs evaluated for a derivative (one solve with the model's
                      sensitivities per Jacobian; a central-difference stencil where the
                      sensitivities are not defined)
    ``snap``          snap-pressure continuations (:mod:`dpfexplore.solvers.snap.continuation`)
    ``simulations``   full-dynamics runs (pressure pulse, Rodas4)
    ``screening``     reduced-model reset times (``method="fast"`` or ``"release"``): screening
                      only, never reported
    ``sections``      leg sections simulated in the full model (:mod:`dpfexplore.solvers.legs.leg`)
    ``verifications`` single-design re-solves of reported designs (``find_state``, or a
                      full-model simulation at a tight tolerance for the timing scenes)
    ``seeds``         candidates taken from a sweep dataset (:mod:`~.engine.seeds`):
                      the dataset's exact tips, no model evaluation
"""

from __future__ import annotations

import contextlib
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence

import numba
import numpy as np
from numpy.typing import NDArray

from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS
from ..model.pressure import PressureProfile
from ..solvers.dynamics.simulate import SimulationResult, reset_times_batch, simulate
from ..solvers.statics import solve_batch

__all__ = ["EVALUATION_KINDS", "SceneEvaluator", "few_threads"]

EVALUATION_KINDS = (
    "designs",
    "state_solves",
    "stiffness",
    "derivative",
    "snap",
    "simulations",
    "screening",
    "sections",
    "verifications",
    "seeds",
)
#: Reduced reset-time models: their evaluations count as ``screening``, the others as
#: ``simulations``.
SCREENING_METHODS = ("fast", "release")
#: Batches of at most this many rows run on one thread.
_SMALL_BATCH = 96
#: The same for dynamics (a run costs milliseconds: two designs already share the threads well).
_SMALL_DYNAMICS = 1
#: Sensitivity columns the scenes use, and their width (every parameter of MAX_UNITS units).
_SENSITIVITY_KEYS = ("d_tip_x", "d_tip_y", "d_stiffness")
N_SENSITIVITY_COLUMNS = 3 * MAX_UNITS + 3


@contextlib.contextmanager
def few_threads(rows: int, limit: int = _SMALL_BATCH) -> Iterator[None]:
    """Run the enclosed Numba calls on one thread when ``rows`` is at most ``limit``."""
    if rows > limit:
        yield
        return
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(previous)


class SceneEvaluator:
    """Exact model solves with counts by kind and a record of every evaluated design.

    Parameters
    ----------
    max_units : int
        Widest design of the scene (columns of the history).
    """

    def __init__(self, max_units: int) -> None:
        self.max_units = int(max_units)
        self.counts: Counter[str] = Counter({kind: 0 for kind in EVALUATION_KINDS})
        self._records: list[dict[str, NDArray]] = []
        self.started = time.perf_counter()
        #: ``(designs evaluated, seconds, best objective so far)`` after each recorded batch.
        self.trace: list[tuple[int, float, float]] = []
        self._best = np.inf
        #: Results shared by the targets of one scene run (e.g. a screening grid), by key.
        self.cache: dict = {}
        # Per problem (keyed by identity; problems live as long as their run): the lowest
        # objective seen and its point, and, while archiving, every stiffness evaluation.
        self._best_seen: dict[int, tuple[float, NDArray | None]] = {}
        self._archives: dict[int, list] = {}
        #: Told ``(what, done, total)`` by the optimiser's loops after each evaluation batch
        #: (:meth:`report`); None: nobody listens.
        self.on_batch: Callable[[str, int, int], None] | None = None

    def report(self, what: str, done: int, total: int) -> None:
        """Tell :attr:`on_batch` that ``what`` (``"refining"``) has done ``done`` of ``total``."""
        if self.on_batch is not None:
            self.on_batch(what, done, total)

    # ------------------------------------------------------------------ what problems saw

    def observe(self, problem: object, z: NDArray, objective: NDArray, stiffness=None) -> None:
        """Note an evaluation of ``problem`` at box points ``z``.

        Keeps its best point (:meth:`best_seen`) and, when ``stiffness`` is given and the
        problem is being archived (:meth:`archiving`), the ``(objective, stiffness, z)`` record.
        """
        key = id(problem)
        if len(z):
            i = int(np.argmin(objective))
            if objective[i] < self._best_seen.get(key, (np.inf, None))[0]:
                self._best_seen[key] = (float(objective[i]), z[i].copy())
        if stiffness is not None and key in self._archives:
            self._archives[key].append((objective, stiffness, z))

    def best_seen(self, problem: object) -> tuple[float, NDArray | None]:
        """The lowest objective (mm²) of any evaluated point of ``problem``, and that point."""
        return self._best_seen.get(id(problem), (np.inf, None))

    @contextlib.contextmanager
    def archiving(self, problems: Sequence[object]) -> Iterator[dict[int, list]]:
        """Archive every stiffness evaluation of ``problems`` inside the block.

        Yields the archives, ``id(problem) -> [(objective, stiffness, z), ...]``.
        """
        archives = {id(p): [] for p in problems}
        self._archives.update(archives)
        try:
            yield archives
        finally:
            for key in archives:
                self._archives.pop(key, None)

    # ------------------------------------------------------------------ solving

    def solve(
        self,
        batch: DesignBatch,
        states: Sequence[int] | NDArray,
        *,
        stiffness: Sequence[bool] | NDArray | bool = False,
        derivative: bool = False,
        sensitivities: bool = False,
    ) -> dict[str, NDArray]:
        """Solve ``states[j]`` of every design for each ``j``; columns of shape ``(n, S)``.

        Parameters
        ----------
        batch : DesignBatch
            ``n`` designs.
        states : sequence of int, length ``S``, or ndarray of shape (n, S)
            State integers (unit 1 = most significant bit) to solve for every design.
        stiffness : bool or sequence of bool (length S)
            Which of the states also get their tip stiffness.
        derivative : bool
            Count these designs as evaluations made for a derivative.
        sensitivities : bool
            Also return the model's design sensitivities (``d_tip_x``, ``d_tip_y``,
            ``d_stiffness``: shape ``(n, S, 3·MAX_UNITS + 3)``, columns of
            :func:`dpfexplore.solvers.sensitivities.batch_columns`).

        Returns
        -------
        dict of str to ndarray of shape (n, S)
            ``status``, ``found``, ``tip_x``, ``tip_y`` (mm), ``stiffness`` (N/mm, NaN where
            not asked), ``min_eig`` (N/mm, where stiffness was asked).
        """
        n = len(batch)
        states = np.asarray(states, dtype=np.int64)
        if states.ndim == 1:
            states = np.broadcast_to(states, (n, states.size))
        n_states = states.shape[1]
        want = np.broadcast_to(np.asarray(stiffness, dtype=bool), (n_states,))
        out = {
            **(
                {
                    key: np.full((n, n_states, N_SENSITIVITY_COLUMNS), np.nan)
                    for key in _SENSITIVITY_KEYS
                }
                if sensitivities
                else {}
            ),
            "status": np.empty((n, n_states), np.int8),
            "found": np.empty((n, n_states), np.int64),
            **{
                key: np.full((n, n_states), np.nan)
                for key in ("tip_x", "tip_y", "stiffness", "min_eig", "bend_angle")
            },
        }
        for with_k in (False, True):
            cols = np.flatnonzero(want == with_k)
            if cols.size == 0 or n == 0:
                continue
            rows = np.repeat(np.arange(n), cols.size)
            requested = states[:, cols].reshape(-1)
            with few_threads(rows.size):
                res = solve_batch(
                    batch.take(rows),
                    requested,
                    stiffness=with_k,
                    min_eig=with_k,
                    sensitivities=sensitivities,
                )
            for key in ("status", "found", "tip_x", "tip_y", "bend_angle"):
                out[key][:, cols] = res[key].reshape(n, cols.size)
            if sensitivities:
                for key in _SENSITIVITY_KEYS:
                    out[key][:, cols] = res[key].reshape(n, cols.size, -1)
            if with_k:
                out["stiffness"][:, cols] = res["stiffness"].reshape(n, cols.size)
                out["min_eig"][:, cols] = res["min_eig"].reshape(n, cols.size)
                self.counts["stiffness"] += rows.size
            self.counts["state_solves"] += rows.size
        self.counts["designs"] += n
        if derivative:
            self.counts["derivative"] += n
        return out

    def reset_times(
        self,
        batch: DesignBatch,
        profile: PressureProfile,
        *,
        t_end: float,
        method: str = "rodas4",
        atol: float | None = None,
        verification: bool = False,
    ) -> dict[str, NDArray]:
        """Reset times of ``batch`` under ``profile`` (:func:`reset_times_batch`), counted.

        Reduced models (:data:`SCREENING_METHODS`) count as ``screening``, the full model as
        ``simulations`` (or ``verifications`` when ``verification``). Rows run in parallel
        (small batches on one thread, as :meth:`solve`).
        Note that the batch runs stop once every inverted unit is back below its barrier; where
        a unit may re-invert after that (a neighbour's snap-back pushing it back), use
        :meth:`simulate`, which follows the whole horizon.
        """
        n = len(batch)
        with few_threads(n, _SMALL_DYNAMICS):
            out = reset_times_batch(batch, profile, t_end=t_end, method=method, atol=atol)
        if method in SCREENING_METHODS:
            self.counts["screening"] += n
        else:
            self.counts["verifications" if verification else "simulations"] += n
        self.counts["designs"] += n
        return out

    def simulate(
        self,
        design: Design,
        profile: PressureProfile,
        *,
        t_end: float,
        kind: str = "simulations",
        **options,
    ) -> SimulationResult:
        """One full-model run (:func:`~dpfexplore.solvers.dynamics.simulate.simulate`), as ``kind``.

        Runs to ``t_end`` (no early stop unless asked), so a reset time is the last downward
        crossing of the whole horizon.
        """
        if kind not in EVALUATION_KINDS:
            raise ValueError(f"kind = {kind!r}: one of {EVALUATION_KINDS}")
        options.setdefault("n_samples", 0)
        with few_threads(1):
            result = simulate(design, profile, t_end=t_end, **options)
        self.counts[kind] += 1
        self.counts["designs"] += 1
        return result

    def count(self, kind: str, number: int = 1) -> None:
        """Count evaluations of another kind (``snap``, ``simulations``, ``verifications``)."""
        if kind not in EVALUATION_KINDS:
            raise ValueError(f"kind = {kind!r}: one of {EVALUATION_KINDS}")
        self.counts[kind] += number

    # ------------------------------------------------------------------ history

    def record(self, batch: DesignBatch, **columns: NDArray | float | str) -> None:
        """Add evaluated designs to the history with per-row columns (objective parts...)."""
        n = len(batch)
        if n == 0:
            return
        width = self.max_units
        row: dict[str, NDArray] = {"n_units": batch.n_units.astype(np.int8)}
        for name in ("H", "U_L", "U_sep"):
            values = getattr(batch, name)[:, :width]
            for k in range(width):
                row[f"{name}_{k + 1}"] = values[:, k].copy()
        for name in ("t", "t_lim", "E"):
            row[name] = getattr(batch, name).copy()
        for key, value in columns.items():
            row[key] = np.broadcast_to(np.asarray(value), (n,)).copy()
        row["evaluation"] = np.arange(self.n_recorded, self.n_recorded + n, dtype=np.int64)
        self._records.append(row)
        if "objective" in row:
            finite = row["objective"][np.isfinite(row["objective"])]
            if finite.size:
                self._best = min(self._best, float(np.min(finite)))
        self.trace.append((self.counts["designs"], self.wall_s, self._best))

    def reached(self, threshold: float) -> tuple[int | None, float | None]:
        """Designs evaluated and seconds until the best objective was at most ``threshold``."""
        for count, seconds, best in self.trace:
            if best <= threshold:
                return count, seconds
        return None, None

    def best_at(self, *, evaluations: float = np.inf, seconds: float = np.inf) -> float:
        """Best objective recorded within an evaluation count and a wall time."""
        best = np.inf
        for count, wall, value in self.trace:
            if count > evaluations or wall > seconds:
                break
            best = value
        return best

    @property
    def n_recorded(self) -> int:
        """Designs recorded so far."""
        return sum(len(r["n_units"]) for r in self._records)

    def history(self):
        """Every recorded design as a :class:`pandas.DataFrame` (one row per design)."""
        import pandas as pd

        if not self._records:
            return pd.DataFrame()
        keys: list[str] = []
        for record in self._records:
            keys += [k for k in record if k not in keys]
        frames = []
        for record in self._records:
            n = len(record["n_units"])
            frames.append(
                pd.DataFrame(
                    {k: record[k] if k in record else _missing(record, k, n) for k in keys}
                )
            )
        frame = pd.concat(frames, ignore_index=True)
        return frame[["evaluation", *[k for k in keys if k != "evaluation"]]]

    @property
    def wall_s(self) -> float:
        """Seconds since the evaluator was made."""
        return time.perf_counter() - self.started


def _missing(record: dict[str, NDArray], key: str, n: int) -> NDArray:
    # Columns a record lacks (e.g. stiffness of a position row): NaN for numbers, None else.
    return np.full(n, np.nan)
