"""The documentation site builds with warnings as errors.

One Sphinx build into a temporary folder: every docstring of the API reference, the Markdown
pages, the benchmarks page generated from ``results/reports/bench-*.json`` and the gallery, whose
example scripts run during the build.
"""

from __future__ import annotations

import importlib.util
import json
import re
import subprocess
import sys
from html import unescape
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
DOCS = ROOT / "docs"
REPORTS = ROOT / "results" / "reports"


def _generated_pages():
    spec = importlib.util.spec_from_file_location(
        "generated_pages", DOCS / "_ext" / "generated_pages.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _text(path: Path) -> str:
    return unescape(re.sub(r"<[^>]+>", "", path.read_text(encoding="utf-8")))


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("docs") / "html"
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", str(DOCS), str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-8000:]
    return out


@pytest.mark.slow
def test_docs_build_without_warnings(site):
    for page in ("index", "api", "model", "decisions", "layout", "guide/using", "guide/sweeps"):
        assert (site / f"{page}.html").exists(), page
    # the API reference rendered the public functions from their docstrings
    api = _text(site / "api.html")
    assert "find_state" in api and "run_sweep" in api


@pytest.mark.slow
def test_benchmarks_page_is_read_from_the_records(site):
    fmt = _generated_pages().fmt
    page = _text(site / "_generated" / "benchmarks.html")
    lookup = json.loads((REPORTS / "bench-lookup.json").read_text())
    statics = json.loads((REPORTS / "bench-statics.json").read_text())
    assert fmt(lookup["build"]["rows_indexed"]) in page
    assert fmt(statics["by_n_units"][0]["ours_us_per_design"]) in page
    assert statics["machine"]["date"] in page
    explore = json.loads((REPORTS / "bench-explore.json").read_text())
    grasp = json.loads((REPORTS / "bench-grasp.json").read_text())
    assert f"{fmt(explore['dataset']['rows'])} rows" in page
    assert f"{fmt(explore['zoom']['median_ms'])} / {fmt(explore['zoom']['p90_ms'])}" in page
    assert f"{fmt(grasp['sort']['seconds'])} ({grasp['sort']['failed']} unconverged" in page


@pytest.mark.slow
def test_gallery_images_exist(site):
    scripts = sorted((DOCS / "examples").glob("*.py"))
    assert scripts
    gallery = (site / "_generated" / "gallery.html").read_text(encoding="utf-8")
    for script in scripts:
        image = site / "_images" / f"{script.stem}.png"
        assert image.exists() and image.stat().st_size > 10_000, image
        assert f"{script.stem}.png" in gallery


@pytest.mark.slow
def test_identification_page_shows_the_compare_figure(site):
    # results/reports/shell-extended-compare.png (identify compare --plot), copied into the site
    page = (site / "guide" / "identification.html").read_text(encoding="utf-8")
    image = site / "_images" / "shell-extended-compare.png"
    assert "shell-extended-compare.png" in page
    assert image.exists() and image.stat().st_size > 50_000


@pytest.mark.slow
def test_validation_page_shows_the_report_and_its_figure(site):
    # results/reports/validation.{md,png} (dpfexplore validate --report --plot), included
    page = (site / "guide" / "validation.html").read_text(encoding="utf-8")
    assert "How well it predicts real fingers" in page
    assert "validation.png" in page and "Per set and material" in page
    image = site / "_images" / "validation.png"
    assert image.exists() and image.stat().st_size > 50_000


@pytest.mark.slow
def test_tutorial_page_shows_the_outputs_and_figures(site):
    # the executed copy of docs/tutorial.ipynb (docs/_ext/notebook_outputs.py), not the bare cells
    page = (site / "_generated" / "tutorial.html").read_text(encoding="utf-8")
    assert "reachable: True" in _text(site / "_generated" / "tutorial.html")
    figures = re.findall(r'<img [^>]*src="([^"]*/cell\d+-\d+\.png)"', page)
    assert figures
    for src in figures:
        image = (site / "_generated" / src).resolve()
        assert image.exists() and image.stat().st_size > 10_000, image


@pytest.mark.slow
def test_format_pages_are_in_the_site(site):
    job = _text(site / "formats" / "job-file.html")
    assert "samples_per_n" in job and "integer 1…1073741824" in job
    assert "stiffness" in _text(site / "formats" / "dataset.html")
    assert "targets" in _text(site / "formats" / "scene-file.html")
