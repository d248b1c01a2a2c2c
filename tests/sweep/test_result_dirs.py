"""Result directories are complete or absent: staging, manifest last, one atomic swap, a lock.

Killed at random points (SIGKILL of a real process), interrupted, on a full disk, without
``renameat2``, and raced: afterwards the directory holds the previous complete result or the new
complete one, never a mixture, and :func:`verify_result_dir` passes on it.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from dpfexplore.io import result_dirs as rd
from dpfexplore.io.result_dirs import (
    ResultError,
    ResultExists,
    check_output_dir,
    result_directory,
    verify_result_dir,
)


def write(path, n_files: int, tag: str) -> None:
    with result_directory(path, kind="test", force=True) as staging:
        for i in range(n_files):
            (staging / f"file-{i:02d}.txt").write_text(f"{tag} {i}\n" * 1000)


def contents(path) -> set[str]:
    return {p.read_text().split()[0] for p in path.glob("file-*.txt")}


def test_a_result_replaces_the_previous_one_whole(tmp_path):
    out = tmp_path / "out"
    write(out, 5, "first")
    write(out, 2, "second")
    assert contents(out) == {"second"}
    assert sorted(p.name for p in out.glob("file-*")) == ["file-00.txt", "file-01.txt"]
    assert verify_result_dir(out)["kind"] == "test"
    assert not list(tmp_path.glob(".out.*staging*")) and not list(tmp_path.glob(".out.prev*"))


@pytest.mark.parametrize("error", [RuntimeError("boom"), KeyboardInterrupt()])
def test_a_failure_leaves_the_previous_result_untouched(tmp_path, error):
    out = tmp_path / "out"
    write(out, 3, "first")
    with pytest.raises(type(error)), result_directory(out, kind="test", force=True) as staging:
        (staging / "file-00.txt").write_text("half\n")
        raise error
    assert contents(out) == {"first"} and len(list(out.glob("file-*"))) == 3
    verify_result_dir(out)
    assert not list(tmp_path.glob(".out.staging*"))


def test_an_existing_directory_needs_force_and_a_sweep_never_goes(tmp_path):
    out = tmp_path / "out"
    write(out, 1, "first")
    with pytest.raises(ResultExists, match="a test result") as info:
        check_output_dir(out)
    assert "--force" in str(info.value) and "\n" not in str(info.value)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(ResultExists, match="not a dpfexplore result"):
        check_output_dir(foreign)
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "_manifest.json").write_text("{}")
    with pytest.raises(ResultError, match="sweep dataset"):
        check_output_dir(sweep, force=True)


@pytest.mark.parametrize("name", ["", ".", "..", "/"])
def test_paths_that_are_not_a_directory_of_their_own(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ResultError):
        check_output_dir(name, force=True)


def test_the_working_directory_and_files_are_refused(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    for target in (tmp_path / "sub", tmp_path):
        with pytest.raises(ResultError, match="refusing"):
            check_output_dir(target, force=True)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))  # what Path.home() reads
    with pytest.raises(ResultError, match="refusing"):
        check_output_dir(home, force=True)
    (tmp_path / "afile").write_text("x")
    with pytest.raises(ResultError, match="is a file"):
        check_output_dir(tmp_path / "afile")
    with pytest.raises(ResultError, match="cannot create"):
        check_output_dir(tmp_path / "afile" / "sub")


def test_verify_catches_a_changed_missing_or_extra_file(tmp_path):
    out = tmp_path / "out"
    write(out, 2, "first")
    (out / "file-00.txt").write_text("changed\n")
    with pytest.raises(ResultError, match="changed"):
        verify_result_dir(out)
    write(out, 2, "again")
    (out / "file-01.txt").unlink()
    with pytest.raises(ResultError, match="missing"):
        verify_result_dir(out)
    write(out, 2, "again")
    (out / "stray.txt").write_text("x")
    with pytest.raises(ResultError, match="not part"):
        verify_result_dir(out)


def test_without_renameat2_and_a_kill_between_the_renames(tmp_path, monkeypatch):
    out = tmp_path / "out"
    write(out, 2, "first")
    monkeypatch.setenv("DPFEXPLORE_NO_RENAMEAT2", "1")
    write(out, 3, "second")
    assert contents(out) == {"second"} and verify_result_dir(out)
    # a writer killed after moving the previous result aside, before the new one went in
    os.rename(out, tmp_path / ".out.old-dead")
    write(out, 1, "third")  # the next writer restores, then replaces
    assert contents(out) == {"third"}
    assert not list(tmp_path.glob(".out.old-*"))
    os.rename(out, tmp_path / ".out.previous-dead")  # the name earlier versions used
    with pytest.raises(RuntimeError), result_directory(out, kind="test", force=True):
        raise RuntimeError("fails after recovery")
    assert contents(out) == {"third"}  # recovered, and kept


def test_a_second_writer_is_refused_and_a_stale_empty_lock_is_taken_over(tmp_path):
    out = tmp_path / "out"
    with result_directory(out, kind="test") as staging:
        (staging / "file-00.txt").write_text("one\n")
        with pytest.raises(ResultError, match="another command is writing"):
            check = result_directory(out, kind="test", force=True)
            check.__enter__()
    lock = tmp_path / ".out.dpfexplore-lock"
    lock.write_text("")  # what a writer killed between create and write leaves
    old = time.time() - 10
    os.utime(lock, (old, old))
    write(out, 1, "after")
    assert contents(out) == {"after"}


KILLED_WRITER = textwrap.dedent(
    """
    import sys, time
    from dpfexplore.io.result_dirs import result_directory
    out, tag = sys.argv[1], sys.argv[2]
    print("ready", flush=True)  # imported: the kill lands in the write, not in the imports
    start = time.perf_counter()
    with result_directory(out, kind="test", force=True) as staging:
        for i in range(40):
            (staging / f"file-{i:02d}.txt").write_text(f"{tag} {i}\\n" * 20000)
    print(time.perf_counter() - start, flush=True)
    """
)


def test_sigkill_at_random_points_leaves_one_complete_result(tmp_path):
    out = tmp_path / "out"
    write(out, 40, "first")
    script = tmp_path / "writer.py"
    script.write_text(KILLED_WRITER)
    env = {**os.environ}

    def start(tag: str, *, fallback: bool) -> subprocess.Popen:
        env.pop("DPFEXPLORE_NO_RENAMEAT2", None)
        if fallback:
            env["DPFEXPLORE_NO_RENAMEAT2"] = "1"
        process = subprocess.Popen(
            [sys.executable, str(script), str(out), tag], stdout=subprocess.PIPE, env=env, text=True
        )
        assert process.stdout.readline().strip() == "ready"
        return process

    # one write left alone: how long the part worth killing takes (files, manifest, swap)
    process = start("timed", fallback=False)
    duration = float(process.stdout.readline())
    assert process.wait() == 0 and contents(out) == {"timed"}
    current, outcomes = "timed", set()
    rng = random.Random(20261203)
    delays = [0.0] + [rng.uniform(0.0, 1.5 * duration) for _ in range(7)]
    for i, delay in enumerate(delays):
        tag = f"run{i}"
        process = start(tag, fallback=i % 2 == 1)  # every other one without renameat2
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        if not out.exists():  # killed between the fallback's two renames: the old one is aside
            (aside,) = tmp_path.glob(".out.old-*")
            verify_result_dir(aside)
            assert contents(aside) == {current}
        else:
            present = contents(out)
            assert present in ({current}, {tag}), present  # never a mixture
            assert len(list(out.glob("file-*"))) == 40
            verify_result_dir(out)
            outcomes.add("new" if present == {tag} else "old")
            current = present.pop()
        lock = tmp_path / ".out.dpfexplore-lock"
        if lock.exists() and lock.stat().st_size == 0:  # killed between creating and filling it
            os.utime(lock, (time.time() - 10, time.time() - 10))
    assert "old" in outcomes  # at least one kill landed before the swap
    # the next writer takes over the dead writers' lock and clears what they left
    process = start("last", fallback=False)
    process.stdout.readline()
    assert process.wait() == 0 and contents(out) == {"last"}
    verify_result_dir(out)
    assert sorted(p.name for p in tmp_path.glob(".out*")) == []


def test_the_manifest_lists_every_file(tmp_path):
    out = tmp_path / "out"
    with result_directory(out, kind="test", description={"n": 2}) as staging:
        (staging / "sub").mkdir()
        (staging / "sub" / "a.bin").write_bytes(b"\0" * 10)
    marker = json.loads((out / rd.RESULT_MARKER).read_text())
    assert marker["files"]["sub/a.bin"]["bytes"] == 10
    assert marker["description"] == {"n": 2}


def test_a_full_disk_while_committing_keeps_the_previous_result(tmp_path, monkeypatch):
    import errno

    out = tmp_path / "out"
    write(out, 3, "first")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(rd, "atomic_write", full)  # the manifest, written last
    with pytest.raises(OSError, match="No space"):
        write(out, 3, "second")
    assert contents(out) == {"first"}
    monkeypatch.undo()
    verify_result_dir(out)
    assert not list(tmp_path.glob(".out.staging*"))
