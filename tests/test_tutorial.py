"""The tutorial notebook (docs/tutorial.ipynb) runs from top to bottom.

It is executed once (``docs/_ext/notebook_outputs.py``): this test or the docs build, whichever
comes first, runs it and keeps the executed copy in ``docs/_generated/``, which the docs page
renders with its outputs and figures.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
NOTEBOOK = ROOT / "docs" / "tutorial.ipynb"


def _notebook_outputs():
    spec = importlib.util.spec_from_file_location(
        "notebook_outputs", ROOT / "docs" / "_ext" / "notebook_outputs.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_tutorial_notebook_executes():
    source = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    assert not any(cell.get("outputs") for cell in source["cells"] if cell["cell_type"] == "code")
    notebook, seconds = _notebook_outputs().executed_notebook(
        NOTEBOOK, ROOT / "docs" / "_generated"
    )
    code = [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]
    assert [c["source"] for c in code] == [
        c["source"] for c in source["cells"] if c["cell_type"] == "code"
    ]
    errors = [
        output for cell in code for output in cell["outputs"] if output["output_type"] == "error"
    ]
    assert not errors
    text = "".join("".join(output.get("text", "")) for cell in code for output in cell["outputs"])
    assert "reachable: True" in text
    # its figures are kept for the docs page
    assert any("image/png" in output.get("data", {}) for cell in code for output in cell["outputs"])
    assert seconds < 120
