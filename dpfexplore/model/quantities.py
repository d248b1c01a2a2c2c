"""The tables that declare the model's quantities: a state's outputs, a constants set's forms.

One record per quantity, and everything that computes, stores or describes the quantity reads
that record, so adding one is a row here plus its computation. The module is plain Python (no
NumPy, no Numba) so that the kernels can read it: Numba takes module-level integers as
compile-time constants, so an index derived from a table (``OUT_TIP_X =
STATE_OUTPUT_NAMES.index("tip_x")``) costs nothing at run time.

:data:`STATE_OUTPUTS`
    The outputs of a stable state (MODEL.md §7), one record per column. A record's position is
    its index in the kernels' per-state output vector (``OUT_*`` and ``N_OUT`` of
    :mod:`dpfexplore._kernels.statics.states`); the table gives the columns of
    :func:`~dpfexplore.solvers.statics.solve_batch` (in this order), the field of
    :class:`~dpfexplore.solvers.statics.StateResult` that holds each (checked when that module
    is imported), the sweep dataset's columns with their Arrow type, unit and description
    (:meth:`dpfexplore.sweep.evaluation.StaticsEvaluator.fields`), and the columns a lookup
    re-solves (:data:`dpfexplore.lookup.results.RESOLVED_COLUMNS`).
:data:`SET_FORMS`
    The closed forms a constants set holds (MODEL.md §3, §11), one record per form. A record's
    position is its row in the kernels' closed-form tables (``FORM_*`` and ``N_FORMS`` of
    :mod:`dpfexplore.model.closed_form`; its partials in ``H`` and ``t`` are rows ``2 i`` and
    ``2 i + 1`` of ``DomeBlock.partials``, :mod:`dpfexplore._kernels.tables.set_forms`). The table
    gives the fields of :class:`~dpfexplore.model.constants_set.ConstantsSet` (checked when that
    module is imported), the keys of a set file, what :meth:`ConstantsSet.evaluate` returns, the
    physical checks of :meth:`ConstantsSet.check`, the kernel-table column a quantity fills as it
    is and the rows of its derivatives (:mod:`dpfexplore._kernels.tables.design_tables`), and the
    targets of an identification (:func:`dpfexplore.identification.identify.identify`) with the
    source of their per-curve values.

Adding a per-state output column
    1. A :class:`StateOutput` row in :data:`STATE_OUTPUTS` (name, unit, description; the
       :class:`StateResult` field that holds it). The dataset column, its Arrow type and
       metadata, ``solve_batch``'s column, the kernel index and the lookup follow.
    2. Its computation: ``OUT_NAME = STATE_OUTPUT_NAMES.index("name")`` and the line that
       writes ``out[OUT_NAME]`` in ``state_outputs`` (:mod:`dpfexplore._kernels.statics.states`).
    3. Its field in :class:`~dpfexplore.solvers.statics.StateResult` (with its docstring
       line); importing :mod:`dpfexplore.solvers.statics` fails, naming it, until it is there.
    4. Its line in the schema table of ``docs/guide/sweeps.md``.

    An output the kernels compute only on request (``optional=True``, like ``stiffness``) also
    needs its flag through ``solve_batch``, the kernels' ``RowPlan`` and the job's
    ``[compute]`` table. A design sensitivity of the output is a table of its own
    (:mod:`dpfexplore.solvers.sensitivities`).

Adding a closed form to a constants set
    1. A :class:`SetForm` row in :data:`SET_FORMS` (form name, quantity, unit, description, how
       the quantity scales the dimensionless form, the kernel-table column it fills as it is,
       where identification finds per-curve values, when it is physical). The kernels'
       closed-form tables, derivative rows and the set's file keys, evaluation, checks and
       identification targets follow.
    2. Its field in :class:`~dpfexplore.model.constants_set.ConstantsSet` (importing
       :mod:`dpfexplore.model.constants_set` fails, naming it, until it is there) and the
       paper set's form for it (:data:`~dpfexplore.model.constants_set.DEFAULT`).
    3. Its computation: the kernel-table column it fills (a name in
       ``PHYSICAL_COLUMNS`` of :mod:`dpfexplore._kernels.layout`) and the lattice terms that
       read it (:mod:`dpfexplore._kernels.lattice`, and its design derivatives in
       :mod:`dpfexplore._kernels.sensitivity.states`); a quantity from which a column is computed
       (as the reach ``d`` from ``tip_dis``) is computed in ``_unit_row`` and
       ``_derivative_rows`` of :mod:`dpfexplore._kernels.tables.design_tables`. For identification,
       the per-curve value: a :class:`~dpfexplore.identification.spring_fit.CurveFit` field
       (``source="fit"``) or a column of the curve table (``source="curve"``,
       :mod:`dpfexplore.identification.curves`), and its place in the synthetic curves
       (:mod:`dpfexplore.identification.synthetic`).

    Set files written before the row exist lack the form: bump
    :data:`~dpfexplore.model.constants_set.CONSTANTS_FORMAT`, or read a missing form as a
    default in ``ConstantsSet.from_dict`` and leave a default form out of its ``_body`` (as
    the optional ``hull`` is), so that existing files keep their fingerprints.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = [
    "SCALE_HEIGHT",
    "SCALE_NONE",
    "SCALE_STIFFNESS",
    "SET_FORMS",
    "SET_FORM_NAMES",
    "STATE_OUTPUTS",
    "STATE_OUTPUT_NAMES",
    "SetForm",
    "StateOutput",
    "scaled",
    "unscaled",
]


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


# --------------------------------------------------------------------------- constants sets

#: How a set's dimensionless form ``f(π1, π3)`` gives its quantity: as it is ...
SCALE_NONE = 0
#: ... as a stiffness ``E t²/R · f`` (N/mm for ``E`` in MPa, lengths in mm) ...
SCALE_STIFFNESS = 1
#: ... or as a length ``H · f`` (mm).
SCALE_HEIGHT = 2


@dataclass(frozen=True)
class SetForm:
    """One closed form of a constants set (MODEL.md §3, §11).

    Attributes
    ----------
    name : str
        The form: the key in a set file, the field of
        :class:`~dpfexplore.model.constants_set.ConstantsSet` and the identification target.
    quantity : str
        The quantity it gives: a key of :meth:`ConstantsSet.evaluate`'s result.
    unit : str
        Unit of the quantity (``"1"``: dimensionless).
    description : str
        What the quantity is.
    scale : int
        ``SCALE_*``: how the quantity follows from the form (:func:`scaled`).
    column : str or None
        Name of the kernel-table column that holds the quantity as it is
        (``PHYSICAL_COLUMNS`` of :mod:`dpfexplore._kernels.layout`); its derivatives in ``H``
        and ``t`` fill that column's rows of the derivative table. None: the kernels compute a
        column from it (``tip_dis`` gives the reach ``d``).
    source : {"fit", "curve"}
        Where identification finds a curve's value of the quantity: the field of that name of
        its spring-law fit (:class:`~dpfexplore.identification.spring_fit.CurveFit`), or the
        curve table's column of that name, which may be missing (then the default set's form
        is kept, with a note).
    physical : callable
        ``physical(value, H)``: where the quantity describes a dome of height ``H``
        (elementwise, NumPy arrays); :meth:`ConstantsSet.check` refuses a set that is not
        physical inside its own domain ...
    unphysical : str
        ... naming this.
    """

    name: str
    quantity: str
    unit: str
    description: str
    scale: int
    column: str | None
    source: str
    physical: Callable[[Any, Any], Any]
    unphysical: str


#: The closed forms of a constants set, in the order of the kernels' closed-form tables. The
#: forms are functions of ``π1 = t/H`` and ``π3 = H/R`` (MODEL.md §11).
SET_FORMS: tuple[SetForm, ...] = (
    SetForm(
        name="k_hat",
        quantity="k_b",
        unit="N/mm",
        description="linear stiffness of the dome spring, k_b = E t²/R · k_hat",
        scale=SCALE_STIFFNESS,
        column="k_b",
        source="fit",
        physical=lambda k_b, H: k_b > 0.0,
        unphysical="k_b <= 0",
    ),
    SetForm(
        name="alpha",
        quantity="alpha",
        unit="1",
        description="energy ratio of the dome spring (bistable below 1/9)",
        scale=SCALE_NONE,
        column="alpha",
        source="fit",
        physical=lambda alpha, H: (alpha > 0.0) & (alpha < 1.0),
        unphysical="alpha outside (0, 1)",
    ),
    SetForm(
        name="tip_ratio",
        quantity="tip_dis",
        unit="mm",
        description="inverted apex travel, tip_dis = H · tip_ratio; the reach is "
        "d = tip_dis - H - U_sep - t_ch/2 - t/2",
        scale=SCALE_HEIGHT,
        column=None,
        source="curve",
        physical=lambda tip_dis, H: tip_dis > H,
        unphysical="tip_dis <= H (the inverted apex would not pass flat)",
    ),
)
#: Names of :data:`SET_FORMS`, by row of the kernels' tables.
SET_FORM_NAMES: tuple[str, ...] = tuple(f.name for f in SET_FORMS)


def scaled(scale: int, value: Any, H: Any, t: Any, R: Any, E: Any) -> Any:
    """A quantity from its form's ``value`` (floats or NumPy arrays; mm, MPa).

    The arithmetic of the kernels
    (:func:`~dpfexplore._kernels.tables.set_forms.set_constants_block`) in the same order, so the
    two agree bit for bit.
    """
    if scale == SCALE_STIFFNESS:
        return E * (t * t) / R * value
    if scale == SCALE_HEIGHT:
        return H * value
    return value


def unscaled(scale: int, quantity: Any, H: Any, t: Any, R: Any, E: Any) -> Any:
    """A form's value from its quantity: the inverse of :func:`scaled` (identification)."""
    if scale == SCALE_STIFFNESS:
        return quantity * R / (E * t * t)
    if scale == SCALE_HEIGHT:
        return quantity / H
    return quantity
