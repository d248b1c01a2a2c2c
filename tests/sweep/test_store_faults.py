"""A sweep on a disk that fills up, and verified reads at process exit.

A full disk: one line per lost chunk, no traceback, and a dataset that
stays consistent and resumes to the same bytes as an undisturbed run.

The fault is injected under the package's atomic writer (its ``open``): writes succeed until a
byte budget is spent, then one partial write and ``ENOSPC``, as a full filesystem does.
"""

from __future__ import annotations

import builtins
import errno
import logging
import subprocess
import sys

import pyarrow as pa
import pytest
from sweep_helpers import job_dict, toml_text

from dpfexplore.cli import main
from dpfexplore.io import files
from dpfexplore.sweep.storage import store


class FullDisk:
    """``open`` whose files refuse to grow once ``budget`` bytes were written in all."""

    def __init__(self, budget: int) -> None:
        self.budget = budget

    def __call__(self, path, mode="r", *args, **kwargs):
        handle = builtins.open(path, mode, *args, **kwargs)
        if "w" not in mode:
            return handle
        disk = self

        class Handle:
            def write(self, data):
                data = memoryview(data).cast("B")
                room = max(0, disk.budget)
                handle.write(data[:room])
                disk.budget -= len(data)
                if len(data) > room:
                    raise OSError(errno.ENOSPC, "No space left on device")
                return len(data)

            def __getattr__(self, name):
                return getattr(handle, name)

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                handle.close()

        return Handle()


@pytest.fixture
def job(tmp_path):
    path = tmp_path / "job.toml"
    changes = {"job.samples_per_n": 40, "job.chunk_size": 10, "space.n_units": [2, 3]}
    path.write_text(toml_text(job_dict(**changes)))
    return path


def chunk_bytes(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.glob("N*/part-*.parquet"))}


@pytest.mark.parametrize("budget", [30_000, 0])
def test_full_disk_is_one_line_per_chunk_and_resumes(job, tmp_path, capsys, caplog, budget):
    reference = tmp_path / "reference"
    assert main(["sweep", str(job), "--out", str(reference)]) == 0
    capsys.readouterr()

    out = tmp_path / "out"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(files, "open", FullDisk(budget), raising=False)
        with caplog.at_level(logging.WARNING):
            code = main(["sweep", str(job), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    assert "Traceback" not in err
    assert not any(record.exc_info for record in caplog.records)
    assert "No space left on device" in err and "--resume" in err
    # no half-written file is left where a reader would take it for data
    assert not list(out.rglob("*.tmp"))
    if (out / store.MANIFEST).exists():
        committed = store.read_results(out)  # verified: every committed chunk is intact
        assert len(committed) < len(store.read_results(reference))

    assert main(["sweep", str(job), "--out", str(out), "--resume"]) == 0
    assert chunk_bytes(out) == chunk_bytes(reference)


def test_verified_reads_hand_arrow_no_python_memory(job, tmp_path):
    # Arrow may release a read's input on its own thread after the read returned; a Python
    # `bytes` input then needs the GIL during interpreter exit and the process aborted
    # ("terminate called without an active exception", exit 134). Verified reads therefore
    # decode Arrow-allocated buffers, and a process that exits right after one exits cleanly.
    out = tmp_path / "out"
    assert main(["sweep", str(job), "--out", str(out)]) == 0
    record = next(iter(store.read_manifest(out).chunks.values()))
    assert isinstance(store.chunk_bytes(out, record), pa.Buffer)
    script = (
        "import sys\n"
        "from dpfexplore.sweep.storage.store import read_results\n"
        f"read_results({str(out)!r}, where='n_units == 3')\n"
        "sys.exit(2)\n"
    )
    codes = [
        subprocess.run([sys.executable, "-c", script], capture_output=True).returncode
        for _ in range(8)
    ]
    assert codes == [2] * 8
