"""The tables that declare the model's quantities, and everything that reads them.

A state output is one row of :mod:`dpfexplore.model.quantities`; the kernel indices, the result
record and the dataset schema must follow the rows, and a record whose fields disagree with its
table must fail loudly.
"""

from __future__ import annotations

import numpy as np
import pytest
from model_helpers import FINGER

from dpfexplore import Design, find_state
from dpfexplore._kernels import states as kstates
from dpfexplore.model.design import DesignBatch
from dpfexplore.model.quantities import STATE_OUTPUT_NAMES, STATE_OUTPUTS, StateOutput
from dpfexplore.solvers import statics
from dpfexplore.sweep.evaluation import StaticsEvaluator
from dpfexplore.sweep.space import ComputeSpec


def test_the_kernel_indices_are_the_rows_of_the_table():
    assert kstates.N_OUT == len(STATE_OUTPUTS)
    assert kstates.OUT_TIP_X == STATE_OUTPUT_NAMES.index("tip_x")
    assert kstates.OUT_BEND == STATE_OUTPUT_NAMES.index("bend_angle")
    assert statics.OUTPUT_COLUMNS == {name: i for i, name in enumerate(STATE_OUTPUT_NAMES)}


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
