"""Every file the tool reads is bounded: the size table, special files, and a walk of the package.

The walk (:func:`test_every_file_read_goes_through_the_bounded_reader`) parses every module and
finds each call that reads a file (``open`` for reading, ``Path.read_text``/``read_bytes``,
``np.load``, ``json.load``, ``tomllib.load``, pandas' and pyarrow's readers of a path). A reading
call passes when its function also checks the file first (``read_bounded``, ``check_file`` or
a helper built on them) or reads bytes already in memory (``io.BytesIO``); otherwise its module
must be in :data:`NOT_A_USER_FILE`, each entry with its reason. A new unbounded read fails here.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

from dpfexplore.io.files import (
    SIZE_LIMITS,
    BoundedReadError,
    check_file,
    read_bounded,
)
from dpfexplore.io.toml_fields import FieldError, read_toml

ROOT = Path(__file__).parents[2]
PACKAGE = ROOT / "dpfexplore"

#: Calls that bound a read: a function that makes one of them checks its file first.
BOUNDED = {
    "read_bounded",
    "check_file",
    "read_toml",
    "unverified_chunk",
    "chunk_bytes",
    "verified_bytes",
    "read_file_buffer",
    "open_chunk",
}
#: Methods that read the file they are called on (``Path.read_text``).
PATH_READERS = {"read_text", "read_bytes"}
#: Library functions that read a file named by their first argument.
READERS = {
    "read_parquet",
    "read_csv",
    "read_table",
    "read_schema",
    "read_metadata",
    "ParquetFile",
    "OSFile",
    "memory_map",
    "loadtxt",
    "genfromtxt",
}
#: Modules whose readers (:data:`READERS`, ``load``) read a file.
LIBRARIES = {"np", "numpy", "pd", "pandas", "pq", "pa", "pads", "json", "tomllib", "pickle"}
LIBRARIES |= {"joblib", "skops", "sio"}

#: Reads of files the tool itself controls, not files a user names.
NOT_A_USER_FILE = {
    "io/files.py": "file_sha256 hashes a committed file in 1 MiB blocks (memory bounded)",
    "bench/": "benchmarks read /proc/cpuinfo and their own figures",
}


def _name(node: ast.AST) -> str | None:
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else None


def _writes(call: ast.Call) -> bool:
    """Whether an ``open(...)`` call opens for writing (its mode has w, a, x or +)."""
    mode = call.args[1] if len(call.args) > 1 else None
    for keyword in call.keywords:
        if keyword.arg == "mode":
            mode = keyword.value
    if isinstance(call.func, ast.Attribute) and call.args:  # Path.open(mode)
        mode = call.args[0]
    if isinstance(mode, ast.Constant) and isinstance(mode.value, str):
        return any(c in mode.value for c in "wax+")
    return False


def _reads_a_file(call: ast.Call) -> bool:
    func = call.func
    name = _name(func)
    if call.args and isinstance(call.args[0], ast.Call) and _name(call.args[0].func) == "BytesIO":
        return False  # bytes in memory, read bounded before
    if name == "open":
        if isinstance(func, ast.Attribute) and _name(func.value) in {"os", "gzip"}:
            return False  # os.open: a descriptor whose kind the caller checks
        return not _writes(call)
    if not isinstance(func, ast.Attribute):
        return False
    if name in PATH_READERS:
        return True
    return (name in READERS or name == "load") and _name(func.value) in LIBRARIES


def _unbounded_reads(path: Path) -> list[str]:
    relpath = path.relative_to(PACKAGE)
    source = path.read_text(encoding="utf-8")
    if not any(word in source for word in ("open(", "read_", "load(", "File(", "loadtxt")):
        return []  # nothing that could read a file: not parsed (keeps the walk fast)
    return [f"{relpath}:{hit}" for hit in _unbounded_calls(source)]


def _unbounded_calls(source: str) -> list[str]:
    """``LINE FUNCTION`` of each reading call in a function that bounds no read."""
    tree = ast.parse(source)
    found = []
    for function in ast.walk(tree):
        if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        calls = [n for n in ast.walk(function) if isinstance(n, ast.Call)]
        if any(_name(c.func) in BOUNDED for c in calls):
            continue
        for call in calls:
            if _reads_a_file(call):
                found.append(f"{call.lineno} {function.name}")
    return sorted(set(found))


def _allowed(relpath: str) -> bool:
    return any(
        relpath == key or (key.endswith("/") and relpath.startswith(key)) for key in NOT_A_USER_FILE
    )


def test_every_file_read_goes_through_the_bounded_reader():
    unbounded = [
        hit
        for path in sorted(PACKAGE.rglob("*.py"))
        if "_kernels" not in path.parts
        for hit in _unbounded_reads(path)
        if not _allowed(hit.split(":")[0])
    ]
    assert not unbounded, "read through dpfexplore.io.files.read_bounded:\n" + "\n".join(unbounded)


def test_the_walk_finds_unbounded_reads():
    # Guards the rule above against a walker that silently finds nothing.
    source = (
        "def f(p):\n    return p.read_text()\n\n"
        "def g(p):\n    return open(p, 'wb')\n\n"
        "def h(p):\n    return np.load(p)\n\n"
        "def k(p):\n    check_file(p, 'chunk')\n    return pq.read_table(p)\n\n"
        "def m(raw):\n    return pd.read_parquet(io.BytesIO(raw))\n\n"
        "def n(p):\n    return pd.read_csv(p)\n"
    )
    assert _unbounded_calls(source) == ["18 n", "2 f", "8 h"]


def test_the_allow_lists_name_files_that_exist():
    for key in NOT_A_USER_FILE:
        assert (PACKAGE / key).exists(), key


# ----------------------------------------------------------------------------- the size table


def test_every_limit_has_a_reason_and_a_name():
    for kind, limit in SIZE_LIMITS.items():
        assert limit.bytes >= 1 << 16, kind
        assert limit.what and len(limit.reason) > 20, kind


def test_a_file_over_its_limit_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "big.toml"
    with open(path, "wb") as fh:  # a sparse file: large by stat, nothing written
        fh.truncate(SIZE_LIMITS["design"].bytes + 1)
    with pytest.raises(BoundedReadError, match=r"big.toml: 65537 bytes, more than the limit of "):
        read_bounded(path, "design")
    with pytest.raises(FieldError, match="for a design file"):
        read_toml(path, "design")
    with pytest.raises(BoundedReadError, match="more than the limit"):
        check_file(path, "design")
    assert check_file(path, "job") == 65537


@pytest.mark.parametrize("special", ["/dev/zero", "/dev/null", "fifo", "directory"])
def test_special_files_are_refused_in_one_line_naming_them(tmp_path, special):
    if special == "fifo":
        path = tmp_path / "pipe.toml"
        os.mkfifo(path)
    elif special == "directory":
        path = tmp_path / "folder.toml"
        path.mkdir()
    else:
        path = Path(special)
    with pytest.raises(FieldError) as caught:
        read_toml(path, "scene")
    message = str(caught.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    expected = "is a directory, not a scene file" if special == "directory" else "not a regular"
    assert expected in message
