"""Sphinx configuration of the dpfexplore documentation.

Build with ``.venv/bin/python -m sphinx -b html docs docs/_build/html``. The pages are Markdown
(MyST), the API reference comes from the numpydoc docstrings, and the benchmarks, gallery and
tutorial pages are generated at build time by :mod:`generated_pages` (``docs/_ext``) into
``docs/_generated/`` (git-ignored).
"""

from __future__ import annotations

import os
import sys
from importlib.metadata import version as _version
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

project = "dpfexplore"
author = "dpfexplore developers"
copyright = "dpfexplore developers"
release = _version("dpfexplore")
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "generated_pages",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
# MODEL.md is included by model.md (it stays where the code and tests refer to it); _ext holds the
# extension and the benchmarks page's template, examples/ the gallery's scripts: none is a page.
exclude_patterns = [
    "_build",
    "_ext",
    "MODEL.md",
    "examples",
    "_generated/api_public.rst",
    "Thumbs.db",
    ".DS_Store",
]

myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3

autosummary_generate = False
autodoc_typehints = "none"  # numpydoc renders the documented types
autodoc_default_options = {"members": True, "member-order": "bysource"}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

intersphinx_mapping: dict[str, tuple[str, None]] = {}

html_theme = "alabaster"
html_title = "dpfexplore"
html_static_path: list[str] = []
html_theme_options = {"description": "Design-space explorer for Dome Phalanx Fingers"}
