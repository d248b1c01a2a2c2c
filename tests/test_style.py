"""The formatter and the linter decide the layout: CI fails on unformatted code."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]
TARGETS = ["dpfexplore", "tests", "scripts"]


def _ruff(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ruff", *args, *TARGETS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )


def test_ruff_format_check_passes():
    result = _ruff("format", "--check")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_check_passes():
    result = _ruff("check")
    assert result.returncode == 0, result.stdout + result.stderr


def test_few_fmt_skip_markers():
    markers = sum(
        path.read_text().count("fmt: " + "skip")
        for target in TARGETS
        for path in (ROOT / target).rglob("*.py")
    )
    assert markers <= 5


# The layout rules, kept by the suite rather than by a one-off read.
PACKAGE = ROOT / "dpfexplore"
#: Decorators that make a Numba function: the project's policy (``kernel``, ``batch_kernel``,
#: ``jitable``) and Numba's own names, in case a module bypasses the policy.
JIT_DECORATORS = {"kernel", "batch_kernel", "jitable", "njit", "jit", "register_jitable"}
#: The tuple in which a module of ``model/`` lists the plain functions kernels compile inline.
COMPILED_INLINE = "COMPILED_INLINE"
MAX_KERNEL_PARAMETERS = 8
MAX_MODULE_LINES = 600
MAX_FLAT_MODULES = 15


def _decorator_name(node: ast.expr) -> str | None:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else None


def _compiled_inline(tree: ast.Module) -> set[str]:
    """Names a module lists in its ``COMPILED_INLINE`` tuple (compiled by the kernels)."""
    names = set()
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == COMPILED_INLINE for t in node.targets
        ):
            names |= {e.id for e in getattr(node.value, "elts", ()) if isinstance(e, ast.Name)}
    return names


def _jitted_functions() -> dict[str, int]:
    """``module:function`` -> number of parameters, for every function Numba compiles.

    JIT-decorated functions, and the plain functions a module lists in ``COMPILED_INLINE`` (the
    kernels compile those: ``dpfexplore/_kernels/tables/model_forms.py``).
    """
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        inline = _compiled_inline(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and (
                any(_decorator_name(d) in JIT_DECORATORS for d in node.decorator_list)
                or node.name in inline
            ):
                a = node.args
                count = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                found[f"{path.relative_to(PACKAGE)}:{node.name}"] = count
    return found


def test_the_kernel_finder_sees_the_kernels():
    # Guards the rule below against a finder that silently finds nothing.
    names = {key.split(":")[1] for key in _jitted_functions()}
    assert {"minimize", "follow", "set_constants_block"} <= names
    assert {"k_t_form", "constant_derivatives_form", "geometry_status"} <= names
    assert len(names) > 100


def test_no_jitted_function_has_more_than_eight_parameters():
    wide = {k: n for k, n in _jitted_functions().items() if n > MAX_KERNEL_PARAMETERS}
    assert not wide, f"pass named records (dpfexplore/_kernels/records.py): {wide}"


def test_no_module_is_longer_than_600_lines():
    long = {
        str(path.relative_to(ROOT)): n
        for path in PACKAGE.rglob("*.py")
        if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES
    }
    assert not long, long


def test_no_package_holds_more_than_15_flat_modules():
    wide = {}
    for package in PACKAGE.rglob("__init__.py"):
        modules = [p for p in package.parent.glob("*.py") if p.name != "__init__.py"]
        if len(modules) > MAX_FLAT_MODULES:
            wide[str(package.parent.relative_to(ROOT))] = len(modules)
    assert not wide, wide


def _imported_modules(tree: ast.Module) -> set[str]:
    """Top-level names of the modules ``tree`` imports, anywhere in it (absolute imports)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.add(node.module.split(".")[0])
    return found


def test_the_model_imports_no_numba():
    # model/ says what a finger is; the kernels compile its plain functions (COMPILED_INLINE)
    numba = {
        str(path.relative_to(ROOT))
        for path in (PACKAGE / "model").rglob("*.py")
        if "numba" in _imported_modules(ast.parse(path.read_text(), filename=str(path)))
    }
    assert not numba, numba


def test_the_numba_finder_sees_numba_imports():
    # Guards the rule above against a finder that silently finds nothing.
    tree = ast.parse((PACKAGE / "_kernels" / "_jit.py").read_text())
    assert "numba" in _imported_modules(tree)
    assert "numba" in _imported_modules(ast.parse("def f():\n    from numba import njit\n"))
