"""The tables that declare the model's quantities, and everything that reads them.

A state output or a constants set's form is one row of :mod:`dpfexplore.model.quantities`; the
kernel indices, the result records, the dataset schema, the set files and identification must
follow the rows, and a record whose fields disagree with its table must fail loudly.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from model_helpers import FINGER

from dpfexplore import Design, find_state
from dpfexplore._kernels import layout as lay
from dpfexplore._kernels.statics import states as kstates
from dpfexplore._kernels.tables import design_tables as ktables
from dpfexplore._kernels.tables import set_forms
from dpfexplore.model import closed_form, constants_set
from dpfexplore.model.constants_set import DEFAULT, ConstantsSet
from dpfexplore.model.design import DesignBatch
from dpfexplore.model.quantities import (
    SCALE_HEIGHT,
    SCALE_NONE,
    SCALE_STIFFNESS,
    SET_FORM_NAMES,
    SET_FORMS,
    STATE_OUTPUT_NAMES,
    STATE_OUTPUTS,
    StateOutput,
    scaled,
    unscaled,
)
from dpfexplore.solvers import statics
from dpfexplore.solvers.lattice import kernel_tables
from dpfexplore.sweep.evaluation import StaticsEvaluator
from dpfexplore.sweep.space import ComputeSpec


def test_the_kernel_indices_are_the_rows_of_the_tables():
    assert kstates.N_OUT == len(STATE_OUTPUTS)
    assert kstates.OUT_TIP_X == STATE_OUTPUT_NAMES.index("tip_x")
    assert kstates.OUT_BEND == STATE_OUTPUT_NAMES.index("bend_angle")
    assert statics.OUTPUT_COLUMNS == {name: i for i, name in enumerate(STATE_OUTPUT_NAMES)}
    assert closed_form.N_FORMS == len(SET_FORMS)
    assert set_forms.N_SET_PARTIALS == 2 * len(SET_FORMS)
    assert closed_form.FORM_ALPHA == SET_FORM_NAMES.index("alpha")
    for form, column in zip(SET_FORMS, ktables.FORM_COLUMNS, strict=True):
        want = -1 if form.column is None else lay.PHYSICAL_COLUMNS.index(form.column)
        assert column == want
    assert ktables.DC_H == lay.COL_U_LO == len(lay.PHYSICAL_COLUMNS)


@pytest.mark.parametrize(("stiffness", "min_eig"), [(True, True), (False, True), (False, False)])
def test_the_dataset_columns_are_the_rows_of_the_outputs_table(stiffness, min_eig):
    evaluator = StaticsEvaluator(ComputeSpec(stiffness=stiffness, min_eig=min_eig))
    fields = {f.name: f for f in evaluator.fields(3)}
    asked = {"stiffness": stiffness, "min_eig": min_eig}
    for output in STATE_OUTPUTS:
        if output.optional and not asked[output.name]:
            assert output.name not in fields
            continue
        meta = fields[output.name].metadata
        assert meta[b"unit"].decode() == output.unit
        assert meta[b"description"].decode() == output.description
        assert fields[output.name].type.to_pandas_dtype() == np.dtype(output.dtype)
    names = list(fields)
    kept = [o.name for o in STATE_OUTPUTS if o.name in fields]
    assert names[names.index(kept[0]) : names.index(kept[-1]) + 1] == kept  # in table order


def test_a_state_result_holds_every_output_where_its_row_says():
    design = Design(**FINGER)
    result = find_state(design, "111")
    columns = statics.solve_batch(DesignBatch.from_designs([design]), [0b111])
    for output in STATE_OUTPUTS:
        value = getattr(result, output.attribute)
        if output.key is not None:
            value = value[output.key]
        assert value == columns[output.name][0] or (np.isnan(value) and output.optional)
    assert isinstance(result.tip, np.ndarray) and result.tip.dtype == np.float64
    assert list(result.energy_split) == ["linear", "dome", "torsion"]


def test_a_table_row_without_its_record_field_fails_at_import(monkeypatch):
    extra = StateOutput("tip_speed", "mm/s", "not an output", "tip_speed")
    monkeypatch.setattr(statics, "STATE_OUTPUTS", (*STATE_OUTPUTS, extra))
    with pytest.raises(ImportError, match="rows without a field: \\['tip_speed'\\]"):
        statics._check_result_fields()
    monkeypatch.setattr(constants_set, "SET_FORMS", SET_FORMS[:2])
    with pytest.raises(ImportError, match="SET_FORMS and ConstantsSet disagree"):
        constants_set._check_form_fields()


def test_a_constants_set_follows_the_forms_table():
    fields = [f.name for f in dataclasses.fields(ConstantsSet) if f.type == "ClosedForm"]
    assert fields == list(SET_FORM_NAMES)
    data = DEFAULT.to_dict()
    assert all(name in data for name in SET_FORM_NAMES)
    values = DEFAULT.evaluate(4.0, 0.8, 5.0, 26.0)
    assert list(values) == [form.quantity for form in SET_FORMS]
    powers, coefficients = DEFAULT.kernel_forms()
    assert powers.shape[0] == coefficients.shape[0] == len(SET_FORMS)
    # every quantity the kernel table holds as it is, bit for bit in its column
    design = Design(**FINGER)
    table = kernel_tables(DesignBatch.from_designs([design])).unit_params[0, :3]
    want = DEFAULT.evaluate(np.array(FINGER["H"]), design.t, design.r_b, design.E)
    for form in SET_FORMS:
        if form.column is not None:
            column = lay.PHYSICAL_COLUMNS.index(form.column)
            np.testing.assert_array_equal(table[:, column], want[form.quantity])


@pytest.mark.parametrize("scale", [SCALE_NONE, SCALE_STIFFNESS, SCALE_HEIGHT])
def test_a_scale_and_its_inverse(scale):
    H, t, R, E = 4.0, 0.8, 5.125, 26.0
    value = 0.37
    assert unscaled(scale, scaled(scale, value, H, t, R, E), H, t, R, E) == pytest.approx(value)
