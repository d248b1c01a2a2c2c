"""``identify report`` text: the count it states for a closed form is the form it prints."""

from __future__ import annotations

import json
import re

from dpfexplore.identification.report import format_report
from dpfexplore.model.constants_set import PACKAGED_DIR


def test_stated_term_counts_are_the_printed_forms():
    report = json.loads((PACKAGED_DIR / "shell-extended.report.json").read_text())
    text = format_report(report)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 100
    for target, form in report["closed_forms"].items():
        (at,) = [i for i, line in enumerate(lines) if line.startswith(f"  {target}: ")]
        said = int(re.match(rf"  {target}: (\d+) terms? plus a constant", lines[at]).group(1))
        # the printed form: its lines up to the held-out line, one "π" monomial per term
        body = []
        for line in lines[at + 1 :]:
            if line.lstrip().startswith("held-out"):
                break
            body.append(line)
        printed = " ".join(body).partition("=")[2].split()
        coefficients = [t for t in printed if re.fullmatch(r"[+-][0-9.e+-]+", t)]
        assert len(coefficients) == said + 1  # and the constant
        assert said == form["n_terms"]  # the selection's own count
        # the held-out counts name the constant apart: stored counts include it
        end = at + 1 + len(body)
        for name in ("rfecv", "lasso"):
            (line,) = [x for x in lines[end : end + 3] if x.startswith(f"      {name}: ")]
            stated = int(re.match(rf"      {name}: (\d+) terms? \+ constant", line).group(1))
            assert stated == form["heldout"][name]["terms"] - 1
            assert line.endswith("(the better)") == (form["heldout"]["winner"] == name)
