"""What a sweep computes for a chunk of designs, and the dataset columns it fills.

An *evaluator* turns a :class:`~dpfexplore.model.design.DesignBatch` into row-aligned column arrays:
one row per design-state, with ``design_index`` pointing into the batch. It declares its columns
up front (:meth:`StaticsEvaluator.fields`), which fixes the dataset schema before anything is
evaluated. Evaluators are plain picklable objects so that Dask workers can run them.

:class:`StaticsEvaluator` is the evaluator of every job: it calls
:func:`dpfexplore.solvers.statics.solve_batch` for the states the job asks for and, when the job
asks for reset times, :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch` for every valid
design. A static screen would be cheaper but is not safe: a dome that is bistable in isolation
(``alpha < 1/9``, MODEL.md §4) can reset inside its finger, whose bending stiffness adds to its
restoring force (a 5-unit finger of H = 3.0 mm domes at t = 0.83 mm, alpha = 0.104, resets
after 3.3 s).
Nothing the job does not ask for is computed: ``stiffness`` and ``min_eig`` are passed through to
the solver, and their columns exist only when asked for.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from ..model.design import DesignBatch
from ..model.quantities import STATE_OUTPUTS
from .space import ComputeSpec, PressureLoad
from .storage.store import STATUS_TYPE, column

__all__ = ["Evaluator", "StaticsEvaluator", "state_labels"]

#: Type of the state bit-string columns: one dictionary entry per state of the chunk's N.
STATE_BITS_TYPE = pa.dictionary(pa.int32(), pa.string())


class Evaluator(Protocol):
    """The contract between the sweep and what it computes."""

    def fields(self, max_units: int) -> list[pa.Field]:
        """Output columns (after the design columns), for designs of up to ``max_units`` units."""

    def __call__(self, batch: DesignBatch) -> dict[str, NDArray]:
        """Row-aligned outputs, with ``design_index`` (int64) into ``batch``.

        Keys are the names of :meth:`fields`; a per-unit column ``name_k`` may instead come as
        one array ``name`` of shape ``(n_rows, MAX_UNITS)``.
        """

    def warm_up(self) -> float:
        """Compile (or load from the cache) the kernels it calls; returns seconds."""


def state_labels(n_units: int) -> pa.Array:
    """Bit strings of every state of ``n_units`` units, indexed by state integer."""
    return pa.array([format(s, f"0{n_units}b") for s in range(2**n_units)], pa.string())


def _bits_column(states: NDArray, n_units: int) -> pa.DictionaryArray:
    states = np.asarray(states, dtype=np.int64)
    missing = states < 0
    indices = pa.array(np.where(missing, 0, states).astype(np.int32), pa.int32(), mask=missing)
    return pa.DictionaryArray.from_arrays(indices, state_labels(n_units))


class StaticsEvaluator:
    """Stable states (and optionally reset times) of each design, as a job's ``[compute]`` asks.

    Parameters
    ----------
    compute : ComputeSpec
        What to compute.
    """

    def __init__(self, compute: ComputeSpec) -> None:
        self.compute = compute

    def __repr__(self) -> str:
        return f"StaticsEvaluator({self.compute!r})"

    def kernel_groups(self) -> list[str]:
        """Kernel groups this job compiles (:mod:`dpfexplore.solvers.compilation`).

        The warm-up compiles the serial kernels (``states``) with the parallel ones, so both
        are named in the one notice.
        """
        groups = ["states", "statics"]
        load = self.compute.reset_times
        if load is not None:
            groups.append("release" if load.method == "release" else "reset")
        return groups

    def warm_up(self) -> float:
        """Compile the kernels this job calls (:func:`dpfexplore.sweep.warmup.compile_kernels`)."""
        from .warmup import compile_kernels

        return compile_kernels(self.compute)

    def fields(self, max_units: int) -> list[pa.Field]:
        """State columns, then (with reset times) the per-design dynamics columns."""
        fields = [
            column(
                "requested",
                pa.int64(),
                "1",
                "requested state: inversion vector as an integer, unit 1 = most significant "
                "bit (-1: none, invalid design)",
            ),
            column(
                "requested_bits",
                STATE_BITS_TYPE,
                "1",
                "requested state as a bit string, unit 1 first ('11110')",
            ),
            column(
                "found",
                pa.int64(),
                "1",
                "state the solver settled in (differs from requested when collapsed; -1: none)",
            ),
            column("found_bits", STATE_BITS_TYPE, "1", "found state as a bit string, unit 1 first"),
            column(
                "status", pa.int8(), "1", "outcome code of the row (dpfexplore.model.status.Status)"
            ),
            column(
                "status_label",
                STATUS_TYPE,
                "1",
                "outcome: ok, invalid_input, invalid_constants, outside_domain (a dome "
                "taller than its base radius or its unit; not solved), not_converged, "
                "collapsed (requested state does not exist; outputs describe the found "
                "state), nonfinite, degenerate_geometry, unstable",
            ),
        ]
        fields += [
            column(output.name, pa.from_numpy_dtype(output.dtype), output.unit, output.description)
            for output in STATE_OUTPUTS
            if not output.optional or getattr(self.compute, output.name)
        ]
        fields.append(
            column("n_iter", pa.int32(), "1", "Hessian evaluations over all search attempts")
        )
        if self.compute.reset_times is not None:
            fields += _dynamics_fields(max_units, fast=self.compute.reset_times.method == "fast")
        return fields

    def __call__(self, batch: DesignBatch) -> dict[str, NDArray]:
        """Solve the requested states (and reset times) of a batch of designs of one ``N``."""
        from ..solvers.statics import solve_batch

        compute = self.compute
        rows = solve_batch(
            batch, compute.states, stiffness=compute.stiffness, min_eig=compute.min_eig
        )
        for output in STATE_OUTPUTS:
            if output.optional and not getattr(compute, output.name):
                rows.pop(output.name, None)
        n_units = np.unique(batch.n_units)
        if n_units.size > 1:  # the sweep evaluates one N per chunk; bit labels rely on it
            raise ValueError(f"batch mixes numbers of units {n_units.tolist()}")
        n = int(n_units[0]) if n_units.size else 1
        rows["requested_bits"] = _bits_column(rows["requested"], n)
        rows["found_bits"] = _bits_column(rows["found"], n)
        rows["status_label"] = rows["status"]
        if compute.reset_times is not None:
            per_design = reset_times(batch, compute.reset_times)
            index = rows["design_index"]
            for name, values in per_design.items():
                rows[name] = values[index]
        return rows


def _dynamics_fields(max_units: int, *, fast: bool = False) -> list[pa.Field]:
    fields = [
        column(
            "dyn_status",
            pa.int8(),
            "1",
            "outcome code of the pressure-cycle simulation (per design; invalid designs keep "
            "their input status)",
        ),
        column("dyn_status_label", STATUS_TYPE, "1", "outcome of the simulation, as a label"),
        column(
            "final_state",
            pa.int64(),
            "1",
            "state at the end of the simulation horizon (-1: not simulated)",
        ),
    ]
    per_unit = (
        (
            "reset_time",
            pa.float64(),
            "s",
            "time from the end of release until unit {k} falls back below its barrier "
            "(inf: not within the horizon; NaN: never inverted, no contact or not simulated)",
        ),
        ("snap_through", pa.float64(), "s", "time unit {k} snapped through (inverted)"),
        ("snap_back", pa.float64(), "s", "time unit {k} snapped back"),
        (
            "unit_class",
            pa.int8(),
            "1",
            "class of unit {k} in its finger: 0 bistable, 1 metastable, 2 monostable, "
            "3 no contact (reach d clamped: no inversion in this model), "
            "-1 never inverted or not simulated",
        ),
    )
    if fast:
        fields += [
            column(
                "reset_fallback",
                pa.bool_(),
                "1",
                "the fast reset model fell back to the full model for this design",
            ),
            column(
                "reset_fallback_reason",
                pa.int16(),
                "1",
                "why (bit flags, dpfexplore.solvers.dynamics.fast_reset.FALLBACK_REASONS; 0: none)",
            ),
        ]
        per_unit += (
            (
                "reset_time_lo",
                pa.float64(),
                "s",
                "lower end of the fast model's 90 % interval of reset_time_{k}",
            ),
            (
                "reset_time_hi",
                pa.float64(),
                "s",
                "upper end of the fast model's 90 % interval of reset_time_{k}",
            ),
        )
    for name, dtype, unit, text in per_unit:
        fields += [
            column(f"{name}_{k}", dtype, unit, text.format(k=k), per_unit=True)
            for k in range(1, max_units + 1)
        ]
    return fields


def reset_times(batch: DesignBatch, load: PressureLoad) -> dict[str, NDArray]:
    """Per-design dynamics columns; every valid design is simulated (see the module docstring).

    Invalid designs keep their input status as ``dyn_status`` and empty outputs, as
    :func:`dpfexplore.solvers.dynamics.simulate.reset_times_batch` returns them.
    """
    from ..solvers.dynamics.simulate import PressureProfile, reset_times_batch

    profile = PressureProfile(P0=load.P0, tau=load.tau)
    kwargs = {"t_end": load.t_end}
    if load.method is not None:
        kwargs["method"] = load.method
    if load.max_rel_halfwidth is not None:
        kwargs["max_rel_halfwidth"] = load.max_rel_halfwidth
    out = reset_times_batch(batch, profile, **kwargs)
    out["dyn_status"] = out.pop("status")
    out["dyn_status_label"] = out["dyn_status"]
    if "fallback" in out:
        out["reset_fallback"] = out.pop("fallback")
        out["reset_fallback_reason"] = out.pop("fallback_reason")
    return out
