"""``identify compare`` on whole fingers when the two sets' sequences visit different states."""

from __future__ import annotations

import numpy as np

from dpfexplore.cli import main
from dpfexplore.examples import example_path
from dpfexplore.identification.compare import compare_fingers
from dpfexplore.model.constants_set import DEFAULT, PACKAGED_DIR, find_constants_set
from dpfexplore.model.design import load_design


def test_sequences_that_differ_are_compared_where_both_solved():
    shell = find_constants_set("shell-extended")
    design = load_design(example_path("gripper"))
    states, resets = compare_fingers([shell, DEFAULT], design)
    both = states["shell-extended:found"].notna() & states["paper:found"].notna()
    one = states["shell-extended:found"].isna() ^ states["paper:found"].isna()
    assert both.any() and one.any()  # the gripper's sequences differ under these two sets
    assert states.loc[one, "tip_shift"].isna().all()
    for _, row in states[both].iterrows():
        dx = row["shell-extended:tip_x"] - row["paper:tip_x"]
        dy = row["shell-extended:tip_y"] - row["paper:tip_y"]
        assert row["tip_shift"] == np.hypot(dx, dy)
    assert list(resets["unit"]) == list(range(1, design.n_units + 1))


def test_compare_takes_a_packaged_set_by_name(capsys):
    assert main(["identify", "compare", "shell-extended", "paper", "--design", "gripper"]) == 0
    out = capsys.readouterr().out
    # one table per set's own sequence; lines a terminal shows whole, no Python booleans or NaN
    assert "sequential states under shell-extended" in out
    assert "sequential states under paper" in out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert not {"True", "False", "NaN", "nan"} & set(out.split())
    # the paper set's last tip (46.51, 36.029 mm, its all-inverted request) is printed
    assert "46.51   36.029" in out
    packaged = PACKAGED_DIR / "shell-extended.json"
    assert main(["identify", "report", str(packaged)]) == 2
    assert "not a saved identification" in capsys.readouterr().err
    assert main(["identify", "compare", "no-such-set", "--design", "gripper"]) == 2
    assert "packaged sets: paper, shell-extended" in capsys.readouterr().err
