"""``bench grasp`` at tiny sizes: the record's fields, its goals and the tolerance error."""

from __future__ import annotations

import json

from dpfexplore.cli import main


def test_bench_record_at_tiny_sizes(capsys):
    args = ["bench", "grasp", "--objects", "4", "--map", "3", "--no-compile", "--json"]
    assert main(args) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["benchmark"] == "grasp"
    assert record["goals"] == {"grasp_ms": 5.0, "sort_1e4_s": 30.0, "map_100_s": 60.0}
    one = record["one_grasp"]
    assert 0 < one["grasp_ms"] < one["grasp_with_payload_ms"]
    sort = record["sort"]
    assert sort["objects"] == 4 and sort["failed"] == 0 and sort["seconds"] > 0
    assert sort["scaled_to_1e4_s"] == sort["seconds"] * 2500
    assert record["map"]["points"] == [3, 3]
    error = record["tolerance_error"]
    for key in ("mu_0", "mu_0.5"):
        assert error[key]["grasps_in_contact"] >= 4
    # frictionless, the penetration tolerance bounds the force error: |dF| <= K tol, with the
    # finger's stiffness at a contact K below the penalty's kappa (about 20 N/mm)
    assert 0 < error["mu_0"]["grip_max_abs_err_N"] <= 20.0 * error["tol_mm"]
    assert record["compile_s"] is None
