"""The file-format reference pages (docs/formats/) are what the readers accept, today.

The pages are generated (``docs/_ext/format_pages.py``) from the calls the one TOML field reader
receives while the shipped jobs and scenes are read, and from the dataset schema of a sweep; a
fresh rendering must equal the committed page, and the annotated layouts the pages quote (the
reader modules' docstrings) must name every key the reader accepts.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]


@pytest.fixture(scope="module")
def pages():
    spec = importlib.util.spec_from_file_location(
        "format_pages", ROOT / "docs" / "_ext" / "format_pages.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["job-file.md", "scene-file.md", "dataset.md"])
def test_page_is_the_fresh_rendering(pages, name):
    committed = (ROOT / "docs" / "formats" / name).read_text(encoding="utf-8")
    assert committed == pages.PAGE_RENDERERS[name](), (
        f"docs/formats/{name} is stale: run python docs/_ext/format_pages.py"
    )


@pytest.mark.parametrize("name", ["job-file.md", "scene-file.md"])
def test_layouts_name_every_key_the_reader_accepts(pages, name):
    trace = pages.job_trace() if name == "job-file.md" else pages.scene_trace()
    layout = "\n".join(pages._layout(module) for module in pages.LAYOUTS[name])
    keys = {key for table in trace.tables.values() for key in table}
    assert len(keys) > 20
    missing = sorted(k for k in keys if not re.search(rf"\b{re.escape(k)}\b", layout))
    assert not missing, f"keys the reader accepts that the layout of {name} does not name"


def test_every_table_lists_required_keys_first_seen(pages):
    trace = pages.job_trace()
    assert trace.tables["job"]["seed"] is True and trace.tables["job"]["chunk_size"] is False
    assert 'one of "lhs", "sobol"' in trace.reads["job.sampler"]


def test_query_help_points_to_the_dataset_page(capsys):
    from dpfexplore.cli import main

    with pytest.raises(SystemExit):
        main(["query", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "docs/formats/dataset.md" in text and (ROOT / "docs/formats/dataset.md").is_file()


def test_states_help_names_every_packaged_design(capsys):
    from dpfexplore.cli import main
    from dpfexplore.examples import NAMES, example_path

    with pytest.raises(SystemExit):
        main(["states", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    designs = [n for n in NAMES if "[design]" in example_path(n).read_text(encoding="utf-8")]
    assert designs == ["gripper", "pickplace"]
    for name in designs:
        assert f" {name} " in text
