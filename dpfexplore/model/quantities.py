"""The tables that declare the model's quantities: the outputs of a stable state.

One record per quantity, and everything that computes, stores or describes the quantity reads
that record, so adding one is a row here plus its computation. The module is plain Python (no
NumPy, no Numba) so that the kernels can read it: Numba takes module-level integers as
compile-time constants, so an index derived from a table (``OUT_TIP_X =
STATE_OUTPUT_NAMES.index("tip_x")``) costs nothing at run time.

:data:`STATE_OUTPUTS`
    The outputs of a stable state (MODEL.md §7), one record per column. A record's position is
    its index in the kernels' per-state output vector (``OUT_*`` and ``N_OUT`` of
    :mod:`dpfexplore._kernels.states`); the table gives the columns of
    :func:`~dpfexplore.solvers.statics.solve_batch` (in this order), the field of
    :class:`~dpfexplore.solvers.statics.StateResult` that holds each (checked when that module
    is imported), the sweep dataset's columns with their Arrow type, unit and description
    (:meth:`dpfexplore.sweep.evaluation.StaticsEvaluator.fields`), and the columns a lookup
    re-solves (:data:`dpfexplore.lookup.results.RESOLVED_COLUMNS`).

Adding a per-state output column
    1. A :class:`StateOutput` row in :data:`STATE_OUTPUTS` (name, unit, description; the
       :class:`StateResult` field that holds it). The dataset column, its Arrow type and
       metadata, ``solve_batch``'s column, the kernel index and the lookup follow.
    2. Its computation: ``OUT_NAME = STATE_OUTPUT_NAMES.index("name")`` and the line that
       writes ``out[OUT_NAME]`` in ``state_outputs`` (:mod:`dpfexplore._kernels.states`).
    3. Its field in :class:`~dpfexplore.solvers.statics.StateResult` (with its docstring
       line); importing :mod:`dpfexplore.solvers.statics` fails, naming it, until it is there.
    4. Its line in the schema table of ``docs/guide/sweeps.md``.

    An output the kernels compute only on request (``optional=True``, like ``stiffness``) also
    needs its flag through ``solve_batch``, the kernels' ``RowPlan`` and the job's
    ``[compute]`` table. A design sensitivity of the output is a table of its own
    (:mod:`dpfexplore.solvers.sensitivities`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["STATE_OUTPUTS", "STATE_OUTPUT_NAMES", "StateOutput"]


# --------------------------------------------------------------------------- state outputs


@dataclass(frozen=True)
class StateOutput:
    """One output column of a stable state (MODEL.md §7).

    Attributes
    ----------
    name : str
        Column of :func:`~dpfexplore.solvers.statics.solve_batch` and of a sweep dataset.
    unit : str
        Physical unit of the column (``"1"`` for a number without one).
    description : str
        What the column holds (the dataset's field metadata).
    attribute : str
        Field of :class:`~dpfexplore.solvers.statics.StateResult` that holds the value.
    key : str or int, optional
        Where in that field: a key of a dict field (``energy_split["dome"]``) or an index of
        an array field (``tip[0]``); None for a field that is the value.
    optional : bool
        Computed only on request: ``solve_batch``'s keyword and the job's ``[compute]`` flag of
        the same name; the kernels leave it NaN otherwise, and a dataset has the column only
        when the job asks for it.
    dtype : str
        NumPy name of the dataset column's type. The kernels compute float64.
    """

    name: str
    unit: str
    description: str
    attribute: str
    key: str | int | None = None
    optional: bool = False
    dtype: str = "float64"


#: The outputs of a stable state, in the order of the kernels' output vector and of the
#: dataset's columns.
STATE_OUTPUTS: tuple[StateOutput, ...] = (
    StateOutput("energy", "N·mm", "total elastic energy of the state", "energy"),
    StateOutput(
        "energy_linear", "N·mm", "energy of posts and limiting layer", "energy_split", "linear"
    ),
    StateOutput("energy_dome", "N·mm", "energy of the dome springs", "energy_split", "dome"),
    StateOutput(
        "energy_torsion", "N·mm", "energy of the torsional springs", "energy_split", "torsion"
    ),
    StateOutput("tip_x", "mm", "x of the tip node L_N (MODEL.md §5 frame)", "tip", 0),
    StateOutput("tip_y", "mm", "y of the tip node L_N", "tip", 1),
    StateOutput(
        "bend_angle",
        "rad",
        "heading of the last limiting-layer segment (unwrapped along the finger)",
        "bend_angle",
    ),
    StateOutput(
        "curvature",
        "1/mm",
        "mean curvature: bend angle over the limiting layer's length",
        "curvature",
    ),
    StateOutput(
        "min_eig",
        "N/mm",
        "smallest eigenvalue of the Hessian on the free coordinates",
        "min_eig",
        optional=True,
    ),
    StateOutput(
        "stiffness",
        "N/mm",
        "tip stiffness 1/(n^T H^-1 n) for a force normal to the last limiting-layer segment "
        "(MODEL.md §7)",
        "stiffness",
        optional=True,
    ),
    StateOutput("grad_norm", "N", "largest gradient component at the solution", "grad_norm"),
)
#: Names of :data:`STATE_OUTPUTS`, by kernel index.
STATE_OUTPUT_NAMES: tuple[str, ...] = tuple(o.name for o in STATE_OUTPUTS)
