"""The pipeline order of the packages: written once here, kept by the code and the docs.

Each package of ``dpfexplore`` imports only packages of the levels below its own (module-level
and function-level imports alike), and ``docs/layout.md`` and the package docstring of
``dpfexplore`` list the packages in this order.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).parents[1]
PACKAGE = ROOT / "dpfexplore"

#: The packages from the bottom of the pipeline to the top. Packages of one level import none
#: of each other; each imports only packages of the levels before its own.
PIPELINE = (
    ("numerics", "io", "examples"),
    ("model",),
    ("_kernels",),
    ("solvers",),
    ("plotting",),
    ("grasping",),
    ("measurements",),
    ("sweep",),
    ("lookup",),
    ("surrogates",),
    ("unitcell",),
    ("identification",),
    ("inverse",),
    ("explore",),
    ("bench",),
    ("cli",),
)
LEVEL = {name: level for level, names in enumerate(PIPELINE) for name in names}
ORDER = [name for names in PIPELINE for name in names]


def _imported_packages(path: Path) -> dict[str, int]:
    """Top-level packages of ``dpfexplore`` that ``path`` imports, with a line of each."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    package = parts[:-1]  # the module's package; an __init__ is its own package's module
    found: dict[str, int] = {}
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = [*package[: len(package) - node.level + 1], *(node.module or "").split(".")]
                base = [p for p in base if p]
            else:
                base = (node.module or "").split(".")
            targets = [base] if len(base) > 1 else [[*base, a.name] for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name.split(".") for a in node.names]
        else:
            continue
        for target in targets:
            if target[0] == "dpfexplore" and len(target) > 1:
                found.setdefault(target[1], node.lineno)
    return found


def _packages() -> list[str]:
    return sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file())


def test_every_package_has_its_place_in_the_pipeline():
    missing = [name for name in _packages() if name not in LEVEL]
    assert not missing, f"add {missing} to PIPELINE (tests/test_layout.py) and docs/layout.md"
    assert not [name for name in ORDER if not (PACKAGE / name / "__init__.py").is_file()]


def test_imports_point_down_the_pipeline():
    upward = []
    for name in _packages():
        for path in sorted((PACKAGE / name).rglob("*.py")):
            for other, line in _imported_packages(path).items():
                if other != name and other in LEVEL and LEVEL[other] >= LEVEL[name]:
                    upward.append(f"{path.relative_to(ROOT)}:{line} imports dpfexplore.{other}")
    assert not upward, "\n".join(upward)


def test_the_docs_list_the_packages_in_this_order():
    text = (ROOT / "docs" / "layout.md").read_text(encoding="utf-8")
    tree = text[text.index("```text") : text.index("```", text.index("```text") + 7)]
    listed = [m.group(1) for m in re.finditer(r"^  (\w+)/ ", tree, re.MULTILINE)]
    assert listed == ORDER
    doc = ast.get_docstring(ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8")))
    headings = re.findall(r"^([a-z_]+(?:, [a-z_]+)*)$", doc, re.MULTILINE)
    assert [name for heading in headings for name in heading.split(", ")] == ORDER
