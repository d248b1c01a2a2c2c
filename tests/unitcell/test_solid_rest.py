"""The solid's inverted rest beside the shell's: the thick dome, coarse mesh."""

from __future__ import annotations

import pytest

from dpfexplore.unitcell import unit_cell_curve
from dpfexplore.unitcell.solid_check import MeshSpec
from dpfexplore.unitcell.solid_rest import solid_rest


def test_the_thick_domes_solid_rest_lies_within_two_percent_of_the_shells():
    # the thickest dome of the paper's box: the converged figures (docs/guide/
    # unitcell-crosscheck.md) are +1.8 % travel, -0.2 % energy; a coarse mesh lands close
    shell = unit_cell_curve(3.0, 1.0)
    energy = min(z.energy for z in shell.zero_force_states if z.stable and z.displacement > 3.0)
    rest = solid_rest(3.0, 1.0, guess=shell.tip_dis, mesh=MeshSpec(20, 2, 2, 1.1))
    assert rest.converged and rest.stable
    assert abs(rest.force) < 1e-6
    assert rest.tip_dis / shell.tip_dis - 1 == pytest.approx(0.018, abs=0.006)
    assert rest.energy / energy - 1 == pytest.approx(-0.002, abs=0.01)
