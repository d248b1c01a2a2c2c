"""Stable states, their shapes and stiffness (MODEL.md §6-§7): the Python API over the kernels.

Single designs::

    >>> from dpfexplore import Design, find_state
    >>> finger = Design(H=[3.8187, 4.1549, 4.5246, 4.8239, 2.5], U_L=8.5773, U_sep=1.8232,
    ...                 t=0.8326, t_lim=1.056)
    >>> result = find_state(finger, "11110")
    >>> result.stable, round(float(result.tip[1]), 3)
    (True, 36.029)

Batches (the sweep's entry point): :func:`solve_batch` evaluates every requested state of every
design in parallel and returns plain column arrays.

State conventions: a state is the inversion vector, unit 1 (the base) first, written as a bit
string (``"11110"``) or as the integer with unit 1 as the most significant bit (30).

Sequential states (:func:`sequential_states`) are the ``N + 1`` states met when the units invert
one at a time, as under a slowly rising pressure (MODEL.md §6). The model does not fix the order;
we invert the bistable domes (isolated-dome regime) first, by rising snap force
(:attr:`DomeAnalysis.peak_force`: the dome that needs the least force goes first), then the
domes that cannot stay inverted on their own, ties broken toward the base. For heights rising
toward the tip this is base-first, giving the gripper's 10000, 11000, 11100, 11110 sequence.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._kernels.layout import n_free, n_nodes
from .._kernels.records import NewtonControls
from .._kernels.sensitivity.batch import (
    solve_rows_sensitivities,
    solve_rows_sensitivities_serial,
)
from .._kernels.sensitivity.states import N_SENS, n_parameters
from .._kernels.statics import states as kstates
from .._kernels.statics.batch import solve_rows, solve_rows_serial
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS
from ..model.formatting import num
from ..model.quantities import STATE_OUTPUTS
from ..model.status import Status
from . import sensitivities as sens
from .compilation import announce
from .lattice import KernelTables, design_kernel_tables, kernel_tables
from .row_plan import StateSet, row_plan, sequential_state_table

__all__ = [
    "SolverOptions",
    "StateResult",
    "enumerate_states",
    "find_state",
    "parse_state",
    "sequential_states",
    "solve_batch",
    "state_string",
]


@dataclass(frozen=True)
class SolverOptions:
    """Controls of the Newton solver.

    Attributes
    ----------
    gtol : float, N
        Converged when the largest gradient component is below this (Hessian positive
        definite) ...
    xtol : float, mm
        ... or when the full Newton step is below this. The last Newton step is then taken,
        so in the quadratic regime the result is far closer to the minimum than either
        tolerance. Stiffness and smallest eigenvalue come from the Hessian at the returned
        shape.
    max_iter : int
        Hessian evaluations per attempt before giving up (``NOT_CONVERGED``).
    max_step : float, mm
        Largest coordinate change of a step taken where the Hessian is indefinite.
    """

    gtol: float = 1e-9
    xtol: float = 1e-8
    max_iter: int = 100
    max_step: float = 1.0

    def __post_init__(self) -> None:
        for name in ("gtol", "xtol", "max_step"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} = {num(value)}: must be a finite number > 0")
        if (
            isinstance(self.max_iter, bool)
            or not isinstance(self.max_iter, int)
            or self.max_iter < 1
        ):
            raise ValueError(f"max_iter = {self.max_iter!r}: must be an integer >= 1")

    def kernel_args(self) -> NewtonControls:
        """The kernels' :class:`~dpfexplore._kernels.records.NewtonControls` record."""
        return NewtonControls(
            float(self.gtol), float(self.xtol), int(self.max_iter), float(self.max_step)
        )


DEFAULT_OPTIONS = SolverOptions()
_DEFAULT_CONTROLS = DEFAULT_OPTIONS.kernel_args()


def parse_state(state: str | int | Sequence[int], n_units: int) -> int:
    """State integer (unit 1 = most significant bit) from a bit string, integer or 0/1 sequence.

    Raises
    ------
    ValueError
        If the state does not fit ``n_units`` units.
    """
    if isinstance(state, str):
        text = state.strip()
        if len(text) != n_units or set(text) - {"0", "1"}:
            raise ValueError(
                f"state = {state!r}: need a string of {n_units} characters 0/1, unit 1 first"
            )
        return int(text, 2)
    if isinstance(state, (int, np.integer)) and not isinstance(state, bool):
        if not 0 <= int(state) < 2**n_units:
            raise ValueError(
                f"state = {state!r}: must be in [0, {2**n_units - 1}] for {n_units} units"
            )
        return int(state)
    try:
        bits = list(state)
    except TypeError:  # None, a float, an object: not a state in any of the accepted forms
        raise ValueError(
            f"state = {state!r}: give a bit string ('{'1' * n_units}'), an integer in "
            f"[0, {2**n_units - 1}] or {n_units} entries of 0/1, unit 1 first"
        ) from None
    if len(bits) != n_units or any(b not in (0, 1, True, False) for b in bits):
        raise ValueError(f"state = {state!r}: need {n_units} entries of 0/1, unit 1 first")
    return int("".join(str(int(b)) for b in bits), 2)


def state_string(state: int, n_units: int) -> str:
    """Bit string of a state integer, unit 1 first (``state_string(30, 5) == "11110"``)."""
    return format(int(state), f"0{n_units}b")


@dataclass(frozen=True)
class StateResult:
    """One stable-state search (MODEL.md §7 outputs).

    Attributes
    ----------
    requested, found : str
        Inversion vectors, unit 1 first; ``found`` is where the solver settled ("" if nowhere).
    status : Status
        ``OK`` (requested state exists and was found), ``COLLAPSED`` (it does not: the outputs
        describe ``found``), or a solver failure (outputs NaN).
    energy : float, N·mm
        Total lattice energy.
    energy_split : dict of str to float, N·mm
        ``linear`` (posts and limiting layer), ``dome`` and ``torsion`` parts.
    tip : ndarray of shape (2,), mm
        Tip node ``L_N``.
    bend_angle : float, rad
        Heading of the last limiting-layer segment (unwrapped along the finger).
    curvature : float, 1/mm
        Bend angle over the limiting layer's length.
    min_eig : float, N/mm
        Smallest Hessian eigenvalue (positive at a stable state).
    stiffness : float, N/mm
        Tip stiffness for a force normal to the last layer segment (``inf`` for N = 1).
    grad_norm : float, N
        Largest gradient component at the returned shape.
    nodes : ndarray of shape (2N + 2, 2), mm
        Node positions (row ``2k`` is ``D_k``, row ``2k + 1`` is ``L_k``).
    x : ndarray of shape (4N - 2,), mm
        Free coordinates (kernel order).
    n_iter : int
        Hessian evaluations over all search attempts.
    sensitivities : Sensitivities or None
        Derivatives of the outputs in the design parameters, when asked for
        (:mod:`dpfexplore.solvers.sensitivities`).
    """

    requested: str
    found: str
    status: Status
    energy: float
    energy_split: dict[str, float]
    tip: NDArray
    bend_angle: float
    curvature: float
    min_eig: float
    stiffness: float
    grad_norm: float
    nodes: NDArray
    x: NDArray
    n_iter: int
    sensitivities: sens.Sensitivities | None = None

    @property
    def stable(self) -> bool:
        """True when the requested state exists (a local minimum with that inversion vector)."""
        return self.status == Status.OK


def sequential_states(design: Design) -> list[int]:
    """The ``N + 1`` states of sequential activation (see the module docstring for the order)."""
    table = sequential_state_table(DesignBatch.from_designs([design]))
    return table[0, : design.n_units + 1].tolist()


#: Output columns of :func:`solve_batch` (besides the index and status columns): name -> index
#: in the kernels' output vector, the rows of :data:`~dpfexplore.model.quantities.STATE_OUTPUTS`.
OUTPUT_COLUMNS = {output.name: index for index, output in enumerate(STATE_OUTPUTS)}
#: Fields of :class:`StateResult` that are not per-state outputs of the table.
_RESULT_FIELDS = ("requested", "found", "status", "nodes", "x", "n_iter", "sensitivities")


def _check_result_fields() -> None:
    """Fail at import when the outputs table and :class:`StateResult`'s fields disagree.

    :class:`StateResult` spells its fields out (typed and documented, grouped where outputs
    belong together: ``energy_split``, ``tip``); every field besides :data:`_RESULT_FIELDS` must
    hold outputs of the table, and every row must name one of its fields.
    """
    fields = [f.name for f in dataclasses.fields(StateResult)]
    named = {output.attribute for output in STATE_OUTPUTS}
    holding = set(fields) - set(_RESULT_FIELDS)
    if named != holding:
        raise ImportError(
            "dpfexplore.model.quantities.STATE_OUTPUTS and StateResult disagree: "
            f"fields without a row: {sorted(holding - named)}; "
            f"rows without a field: {sorted(named - holding)}"
        )


_check_result_fields()


#: Batches of up to this many rows run on the calling thread: waking the worker threads of a
#: parallel region costs more than a few solves (from ~0.1 ms idle to milliseconds on a loaded
#: machine), and single designs and small batches are what optimisers and lookup send.
SERIAL_MAX_ROWS = 64


def solve_batch(
    batch: DesignBatch,
    states: StateSet | Sequence[int] = "all_inverted",
    *,
    stiffness: bool = True,
    min_eig: bool = True,
    options: SolverOptions | None = None,
    shapes: bool = False,
    sensitivities: bool = False,
) -> dict[str, NDArray]:
    """Find the requested states of many designs in parallel (Numba ``prange``).

    Parameters
    ----------
    batch : DesignBatch
        Designs; invalid ones (:meth:`DesignBatch.status`) keep one row with their status.
    states : {"all_inverted", "sequential", "all"} or sequence of int
        Which states: the all-inverted one, the ``N + 1`` sequential ones, all ``2^N``, or one
        given state per design.
    stiffness, min_eig : bool
        Compute the tip stiffness / the smallest Hessian eigenvalue (skip what you don't need).
    options : SolverOptions, optional
    shapes : bool
        Also return the free coordinates of every row (``"x"``, NaN-padded to 46 columns).
    sensitivities : bool
        Also return the design sensitivities of every row (:mod:`.sensitivities`): columns
        ``d_tip_x``, ``d_tip_y``, ``d_bend_angle``, ``d_curvature``, ``d_energy``,
        ``d_stiffness``, each of shape ``(n_rows, 3·MAX_UNITS + 3)`` with columns
        ``H_1..H_12, U_L_1..U_L_12, U_sep_1..U_sep_12, t, t_lim, E``
        (:func:`.sensitivities.parameter_names`); NaN beyond a design's ``N``, on rows that
        reached no minimum, and where the Hessian is not positive definite. Collapsed rows get
        the derivatives of the state they collapsed to (``found``).

    Returns
    -------
    dict of str to ndarray
        One entry per row: ``design_index`` (int64), ``requested`` and ``found`` (int64 state
        integers; -1 for none), ``status`` (int8 :class:`Status` codes), ``n_iter`` (int32),
        and one column per output of :data:`~dpfexplore.model.quantities.STATE_OUTPUTS`
        (float64, units there): ``energy``, ``energy_linear``, ``energy_dome``,
        ``energy_torsion``, ``tip_x``, ``tip_y``, ``bend_angle``, ``curvature``, ``min_eig``,
        ``stiffness``, ``grad_norm``; NaN where not computed or not converged.

    Notes
    -----
    Batches of up to :data:`SERIAL_MAX_ROWS` rows run on the calling thread, larger ones in
    parallel; the results are the same. Thread safety: do not call this from several threads of
    one process at once (Numba's default threading layer aborts); run one call per process, e.g.
    Dask worker processes with one thread each.
    """
    tables = kernel_tables(batch, derivatives=sensitivities)
    row_design, row_state = row_plan(batch, states, tables)
    rows = _solve(
        tables,
        row_design,
        row_state,
        stiffness=stiffness,
        min_eig=min_eig,
        options=options,
        shapes=shapes,
        sensitivities=sensitivities,
    )
    return _columns(rows, shapes=shapes)


class _Rows(NamedTuple):
    """Raw outputs of the row kernels (see :func:`_solve`)."""

    row_design: NDArray
    row_state: NDArray
    out: NDArray
    status: NDArray
    found: NDArray
    n_iter: NDArray
    x: NDArray
    sens: NDArray | None
    dx: NDArray | None


def _solve(
    tables: KernelTables,
    row_design: NDArray,
    row_state: NDArray,
    *,
    stiffness: bool,
    min_eig: bool,
    options: SolverOptions | None,
    shapes: bool,
    sensitivities: bool,
    shape_derivatives: bool = False,
    serial: bool | None = None,
) -> _Rows:
    """Run the row kernels on packed tables (serial for small batches, else in parallel).

    ``shape_derivatives`` also keeps ``dx*/dθ`` of every row, ``(n_rows, 46, 39)``; ``serial``
    overrides the choice by :data:`SERIAL_MAX_ROWS`.
    """
    controls = _DEFAULT_CONTROLS if options is None else options.kernel_args()
    n_rows = row_design.shape[0]
    out = np.empty((n_rows, kstates.N_OUT))
    status = np.empty(n_rows, dtype=np.int8)
    found = np.empty(n_rows, dtype=np.int64)
    n_iter = np.empty(n_rows, dtype=np.int32)
    # NaN: the row kernel writes no shape for an invalid design
    x = (
        np.full((n_rows, n_free(MAX_UNITS)), np.nan)
        if shapes or sensitivities
        else np.empty((n_rows, 0))
    )
    # the records' fields as plain tuples: a Python call dispatches them several times faster
    # than named tuples (dpfexplore._kernels, "Records at the entry points")
    args = (
        (tables.unit_params, tables.h, tables.n_units, tables.status),  # DesignTable
        (row_design, row_state, bool(stiffness), bool(min_eig)),  # RowPlan
        tuple(controls),  # NewtonControls
        (out, status, found, n_iter, x),  # StateRows
    )
    if serial is None:
        serial = n_rows <= SERIAL_MAX_ROWS
    announce(["sensitivities"] if sensitivities else ["states" if serial else "statics"])
    table = dx = None
    if sensitivities:
        n_params = n_parameters(MAX_UNITS)
        table = np.empty((n_rows, N_SENS, n_params))
        dx = np.empty((n_rows, n_free(MAX_UNITS), n_params) if shape_derivatives else (0, 0, 0))
        run = solve_rows_sensitivities_serial if serial else solve_rows_sensitivities
        run(
            *args, (tables.derivatives, tables.E), (table, dx)
        )  # DesignDerivatives, SensitivityRows
    else:
        (solve_rows_serial if serial else solve_rows)(*args)
    return _Rows(row_design, row_state, out, status, found, n_iter, x, table, dx)


def warm_up(batch: DesignBatch, *, sensitivities: bool = False) -> None:
    """Compile (or load from Numba's cache) every row kernel :func:`solve_batch` may run.

    Both the serial kernels (small batches) and the parallel ones, so that processes started
    afterwards only load them (see :mod:`dpfexplore.sweep.warmup`).
    """
    tables = kernel_tables(batch, derivatives=sensitivities)
    row_design, row_state = row_plan(batch, "all_inverted", tables)
    for serial in (True, False):
        _solve(
            tables,
            row_design,
            row_state,
            stiffness=True,
            min_eig=True,
            options=None,
            shapes=False,
            sensitivities=sensitivities,
            serial=serial,
        )


def _columns(rows: _Rows, *, shapes: bool) -> dict[str, NDArray]:
    """The column dictionary of :func:`solve_batch`."""
    result = {
        "design_index": rows.row_design,
        "requested": rows.row_state,
        "found": rows.found,
        "status": rows.status,
        "n_iter": rows.n_iter,
    }
    # one copy makes every output column a contiguous row of its own (small batches keep
    # strided views: the copy would cost more than it saves)
    by_column = (
        rows.out.T if rows.out.shape[0] <= SERIAL_MAX_ROWS else np.ascontiguousarray(rows.out.T)
    )
    for index, output in enumerate(STATE_OUTPUTS):  # the kernels compute float64
        column = by_column[index]
        result[output.name] = column if output.dtype == "float64" else column.astype(output.dtype)
    if shapes:
        result["x"] = rows.x
    if rows.sens is not None:
        table = rows.sens
        result.update(
            {name: np.ascontiguousarray(table[:, row]) for name, row in sens.COLUMNS.items()}
        )
    return result


def _results(design: Design, tables: KernelTables, rows: _Rows) -> list[StateResult]:
    """One :class:`StateResult` per row of a single design's solve."""
    n = design.n_units
    nf = n_free(n)
    unit_params = tables.unit_params[0, :n]
    h = float(tables.h[0])
    results = []
    for r in range(rows.status.shape[0]):
        x = rows.x[r, :nf].copy()
        found = int(rows.found[r])
        found_bits = state_string(found, n) if found >= 0 else ""
        nodes = np.empty((n_nodes(n), 2))
        kstates.nodes_of(x, unit_params, h, nodes)
        derivatives = None
        if rows.dx is not None and rows.dx.shape[0] > 0:
            derivatives = sens.from_kernel(
                rows.sens[r], rows.dx[r], n, tables.no_contact[0], found_bits
            )
        results.append(
            StateResult(
                requested=state_string(rows.row_state[r], n),
                found=found_bits,
                status=Status(int(rows.status[r])),
                **_result_outputs(rows.out[r]),
                nodes=nodes,
                x=x,
                n_iter=int(rows.n_iter[r]),
                sensitivities=derivatives,
            )
        )
    return results


def _result_outputs(out: NDArray) -> dict[str, Any]:
    """The :class:`StateResult` fields of one row's output vector, as the table places them.

    A field that is the value gets a Python float, a dict field its entries in table order,
    an array field (``tip``) a float64 array of its entries.
    """
    values = out.tolist()
    fields: dict[str, Any] = {}
    for output, value in zip(STATE_OUTPUTS, values, strict=True):
        if output.key is None:
            fields[output.attribute] = value
        else:
            fields.setdefault(output.attribute, {})[output.key] = value
    for name, entries in fields.items():
        if isinstance(entries, dict) and all(isinstance(k, int) for k in entries):
            fields[name] = np.array([entries[k] for k in range(len(entries))])
    return fields


def find_state(
    design: Design,
    state: str | int | Sequence[int],
    *,
    options: SolverOptions | None = None,
    sensitivities: bool = False,
) -> StateResult:
    """Search the stable state ``state`` of one design (see :mod:`dpfexplore._kernels.statics`).

    Returns the requested minimum when it exists (``status == OK``); otherwise the state it
    collapses to, with ``status == COLLAPSED``. With ``sensitivities=True`` the result carries
    the derivatives of its outputs and shape in every design parameter
    (:class:`~dpfexplore.solvers.sensitivities.Sensitivities`).

    A :class:`Design` is validated when it is made, so this goes straight to the kernels: the
    same ones, with the same results, as :func:`solve_batch` on a batch of this one design.
    """
    requested = parse_state(state, design.n_units)
    tables = design_kernel_tables(design, derivatives=sensitivities)
    rows = _solve(
        tables,
        np.zeros(1, dtype=np.int64),
        np.array([requested], dtype=np.int64),
        stiffness=True,
        min_eig=True,
        options=options,
        shapes=True,
        sensitivities=sensitivities,
        shape_derivatives=sensitivities,
    )
    return _results(design, tables, rows)[0]


def enumerate_states(
    design: Design,
    which: Literal["all", "sequential"] = "all",
    *,
    options: SolverOptions | None = None,
) -> list[StateResult]:
    """Every state (``2^N``) or the ``N + 1`` sequential ones, each found or marked collapsed."""
    if which not in ("all", "sequential"):
        raise ValueError(f"which = {which!r}: choose 'all' or 'sequential'")
    batch = DesignBatch.from_designs([design])
    tables = design_kernel_tables(design)
    row_design, row_state = row_plan(batch, which, tables)
    rows = _solve(
        tables,
        row_design,
        row_state,
        stiffness=True,
        min_eig=True,
        options=options,
        shapes=True,
        sensitivities=False,
    )
    return _results(design, tables, rows)
