"""The kernel cache's digest covers every source the kernels compile, and only those."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from dpfexplore._kernels._cache import (
    KERNELS_DIR,
    clear_stale,
    current_digest,
    kernel_sources,
    sources_digest,
)

PACKAGE = KERNELS_DIR.parent


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def _package(tmp_path: Path) -> Path:
    """A package ``pkg`` laid out as dpfexplore: kernels importing model/, and a cli/ beside."""
    _write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/_kernels/__init__.py": '"""Kernels."""\n',
            "pkg/_kernels/_jit.py": "import numba\n",
            "pkg/_kernels/family/__init__.py": "",
            "pkg/_kernels/family/a.py": "from ...model import forms\nfrom .. import _jit\n",
            "pkg/model/__init__.py": "from .status import OK\n",
            "pkg/model/forms.py": "import numpy as np\n\nfrom .status import OK\n",
            "pkg/model/status.py": "OK = 0\n",
            "pkg/model/unused.py": "X = 1\n",
            "pkg/cli/__init__.py": "",
            "pkg/cli/main.py": "from ..model import forms\n",
        },
    )
    return tmp_path / "pkg" / "_kernels"


def _names(kernels: Path) -> set[str]:
    top = kernels.parent.parent
    return {path.relative_to(top).as_posix() for path in kernel_sources(kernels)}


def test_the_sources_are_the_kernels_and_what_they_import(tmp_path):
    kernels = _package(tmp_path)
    assert _names(kernels) == {
        "pkg/_kernels/__init__.py",
        "pkg/_kernels/_jit.py",
        "pkg/_kernels/family/__init__.py",
        "pkg/_kernels/family/a.py",
        "pkg/model/forms.py",
        "pkg/model/status.py",
    }


def test_a_module_a_kernel_starts_to_import_changes_the_digest(tmp_path):
    kernels = _package(tmp_path)
    before = sources_digest(kernels)
    _write(tmp_path, {"pkg/model/new_form.py": "def form(x):\n    return 2.0 * x\n"})
    assert sources_digest(kernels) == before  # not imported by any kernel yet
    _write(tmp_path, {"pkg/model/forms.py": "from .new_form import form\nfrom .status import OK\n"})
    imported = sources_digest(kernels)
    assert imported != before
    _write(tmp_path, {"pkg/model/new_form.py": "def form(x):\n    return 3.0 * x\n"})
    assert sources_digest(kernels) != imported  # an edit of it counts from now on
    # a module imported by a new kernel module, absolutely, as a name of its package
    _write(
        tmp_path,
        {
            "pkg/_kernels/family/b.py": "import pkg.model.unused\nfrom pkg.model import OK\n",
        },
    )
    assert {"pkg/model/unused.py", "pkg/model/__init__.py"} <= _names(kernels)


def test_a_module_no_kernel_imports_leaves_the_digest_alone(tmp_path):
    kernels = _package(tmp_path)
    before = sources_digest(kernels)
    _write(tmp_path, {"pkg/cli/main.py": "from ..model import forms, status\nX = 2\n"})
    _write(tmp_path, {"pkg/model/unused.py": "X = 2\n", "pkg/cli/extra.py": "Y = 1\n"})
    assert sources_digest(kernels) == before


def test_the_digest_covers_the_model_the_kernels_compile_and_not_the_front_ends():
    names = {path.relative_to(PACKAGE).as_posix() for path in kernel_sources()}
    assert {p.relative_to(PACKAGE).as_posix() for p in KERNELS_DIR.rglob("*.py")} <= names
    model = {name for name in names if name.startswith("model/")}
    assert {
        "model/status.py",
        "model/limits.py",
        "model/domain.py",
        "model/quantities.py",
        "model/constants.py",
        "model/closed_form.py",
        "model/validation.py",
    } <= model
    outside = {name.split("/")[0] for name in names} - {"_kernels", "model", "io", "numerics"}
    assert not outside, outside


def test_a_stale_cache_is_cleared_and_a_current_one_kept(tmp_path):
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    (cache / "lattice.assemble-10.py311.nbi").write_bytes(b"index")
    (cache / "lattice.assemble-10.py311.1.nbc").write_bytes(b"code")
    (cache / "lattice.cpython-311.pyc").write_bytes(b"bytecode")
    assert clear_stale("digest-1", [cache]) == 2
    assert [p.name for p in cache.iterdir() if p.suffix in {".nbi", ".nbc"}] == []
    assert (cache / "lattice.cpython-311.pyc").exists()
    (cache / "lattice.assemble-10.py311.nbi").write_bytes(b"index")
    assert clear_stale("digest-1", [cache]) == 0  # marked current: kept
    assert clear_stale("digest-2", [cache]) == 1


def test_the_remembered_digest_follows_every_change_of_the_sources(tmp_path):
    kernels = _package(tmp_path)
    stamp = tmp_path / "stamp.json"
    first = current_digest(kernels, stamp)
    assert first == sources_digest(kernels) and stamp.exists()
    assert current_digest(kernels, stamp) == first  # read back
    recorded = stamp.read_text()
    # an edit of an imported model module (another size)
    _write(tmp_path, {"pkg/model/status.py": "OK = 00\n"})
    edited = current_digest(kernels, stamp)
    assert edited == sources_digest(kernels) != first and stamp.read_text() != recorded
    # the same size, another time: recomputed all the same
    path = tmp_path / "pkg/model/status.py"
    path.write_text("OK = 10\n")
    os.utime(path, ns=(1, 1))
    assert current_digest(kernels, stamp) == sources_digest(kernels) != edited
    # a new kernel module, even one that imports nothing new
    _write(tmp_path, {"pkg/_kernels/family/c.py": "X = 1\n"})
    assert current_digest(kernels, stamp) == sources_digest(kernels)
    # a source gone
    (tmp_path / "pkg/_kernels/family/c.py").unlink()
    assert current_digest(kernels, stamp) == sources_digest(kernels)
    # a stamp that is not JSON, or names another digest for the same files, is not trusted blindly
    stamp.write_text("{not json")
    assert current_digest(kernels, stamp) == sources_digest(kernels)


def test_the_digest_without_a_writable_stamp_is_computed(tmp_path):
    kernels = _package(tmp_path)
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert current_digest(kernels, blocked / "stamp.json") == sources_digest(kernels)


#: Runs a state search, a reset-times batch and the snap pressures of the gripper; prints how
#: many functions Numba compiled on the way.
KERNELS_RUN = """
import numba.core.event as ev
from dpfexplore import find_state, snap_pressures
from dpfexplore.examples import example_path
from dpfexplore.model.design import DesignBatch, load_design
from dpfexplore.solvers.dynamics.simulate import PressureProfile, reset_times_batch

finger = load_design(example_path("gripper"))
pulse = PressureProfile.pulse(0.7, (0.0, 0.1, 0.2, 0.3))
with ev.install_recorder("numba:compile") as compiled:
    find_state(finger, "11100")
    reset_times_batch(DesignBatch.from_designs([finger]), pulse, t_end=0.5, method="rodas4")
    snap_pressures(finger)
print(len(compiled.buffer))
"""


def test_a_second_process_loads_every_kernel_it_runs_from_the_cache():
    """A new process finds each kernel's cache entry again: nothing compiles the second time (a
    kernel keyed by something that changes between processes, such as a closure over a
    dispatcher, would compile in every process)."""
    for _ in range(2):  # the first fills what the cache lacks
        done = subprocess.run(
            [sys.executable, "-c", KERNELS_RUN], capture_output=True, text=True, check=False
        )
        assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-1] == "0", done.stdout
