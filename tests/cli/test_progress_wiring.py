"""Each long command shows its progress through the one display, and one compile notice."""

from __future__ import annotations

import itertools
import re

import pytest
from numba import njit
from sweep_helpers import job_dict, toml_text
from test_result_commands import scene

from dpfexplore.cli import main
from dpfexplore.inverse.design import design_scene
from dpfexplore.inverse.kinds import load_scene
from dpfexplore.io.progress import Progress
from dpfexplore.solvers import compilation


@pytest.fixture
def fresh_cache_answer(monkeypatch):
    """What a first run sees: every kernel group uncompiled, nothing announced yet."""
    monkeypatch.setattr(compilation, "_SETTLED", set())
    monkeypatch.setattr(compilation, "uncompiled", lambda groups: list(groups))
    yield
    compilation.stop_watching()  # its watchers would tell later tests' compilations


def notices(err: str) -> list[str]:
    return [line for line in err.splitlines() if "compiling the " in line]


def test_the_sweep_prints_one_compile_notice_in_the_displays_format(
    tmp_path, capsys, fresh_cache_answer
):
    job = tmp_path / "job.toml"
    job.write_text(toml_text(job_dict(**{"job.samples_per_n": 6})))
    assert main(["sweep", str(job), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    said = notices(err)
    assert len(said) == 1, err
    assert re.match(
        r"^\d\d:\d\d:\d\d sweep: compiling the states and statics kernels for this machine "
        r"\(first run only: about \d+-\d+ s of CPU on a 2-core AMD EPYC VM",
        said[0],
    ), said[0]
    # then the designs' stage: its first line and its end, done/total
    assert re.search(r"sweep: designs 0/12 \(0 %\)", err) and "designs 12/12 (100 %)" in err


def test_a_command_with_a_notice_says_it_once_in_the_same_format(capsys, fresh_cache_answer):
    assert main(["states", "gripper", "--sequential"]) == 0
    said = notices(capsys.readouterr().err)
    assert len(said) == 1
    assert re.match(r"^\d\d:\d\d:\d\d states: compiling the states kernels", said[0]), said


def test_the_notice_quotes_a_cpu_range_and_the_machine_from_one_table():
    low, high = compilation.COMPILE_CPU_S["states"]
    assert 0 < low <= high
    statics = compilation.COMPILE_CPU_S["statics"]
    # two groups: at least the dearer alone, at most both alone (they share code)
    assert compilation.cpu_range(["states", "statics"]) == (
        f"about {max(low, statics[0])}-{high + statics[1]} s of CPU on a 2-core AMD EPYC VM"
    )


def test_each_compiled_group_is_a_stage_while_numba_compiles(monkeypatch, capsys):
    # two toy groups compiled for real (fractions of a second, no cache): each one a stage
    @njit
    def first(x):
        return x + 1

    @njit
    def second(x):
        return x * 2

    monkeypatch.setitem(compilation.KERNEL_GROUPS, "toy one", (first,))
    monkeypatch.setitem(compilation.KERNEL_GROUPS, "toy two", (second,))
    monkeypatch.setitem(compilation.COMPILE_CPU_S, "toy one", (1, 2))
    monkeypatch.setitem(compilation.COMPILE_CPU_S, "toy two", (3, 4))
    with Progress("test", bar=False) as display:
        watcher = compilation.watch(["toy one", "toy two"])
        assert first(1) == 2 and watcher.current == 0 and watcher.display is display
        assert second(2) == 4 and watcher.current == 1
    assert watcher.stopped and watcher.display is None  # both compiled: it stopped
    compilation.stop_watching()
    assert watcher not in compilation._WATCHERS
    err = capsys.readouterr().err
    assert "test: compiling the toy one kernels, group 1/2 (about 1-2 s of CPU" in err
    assert "test: compiling the toy two kernels, group 2/2 (about 3-4 s of CPU" in err


def test_design_reports_every_evaluation_batch_with_done_and_total(tmp_path):
    spec = load_scene(scene(tmp_path, 2))

    class Recorder:
        def __init__(self):
            self.calls = []

        def start(self, total):
            self.calls.append(("start", total))

        def batch(self, text):
            self.calls.append(("batch", text))

        def advance(self, text):
            self.calls.append(("advance", text))

        def close(self):
            self.calls.append(("close", None))

    seen = Recorder()
    told = design_scene(spec, progress=seen)
    silent = design_scene(spec)
    # a listener changes nothing of the results (bit for bit) but the wall time
    assert [{**r, "wall_s": 0} for r in told.rows] == [{**r, "wall_s": 0} for r in silent.rows]
    assert told.evaluator.counts == silent.evaluator.counts
    assert seen.calls[0] == ("start", 2) and seen.calls[-1] == ("close", None)
    batches = [text for kind, text in seen.calls if kind == "batch"]
    parsed = [re.fullmatch(r"target (\d)/2: (.+) (\d+)/(\d+)", text) for text in batches]
    assert all(parsed), batches
    assert {m[1] for m in parsed} == {"1", "2"}
    assert "target 1/2: screening candidates 8/8" in batches
    refining = [(int(m[3]), int(m[4])) for m in parsed if m[2] == "refining"]
    assert refining and all(1 <= done <= total <= 15 for done, total in refining)
    # each refinement counts its evaluations 1, 2, 3 ... against its budget
    for (done, total), (after, of) in itertools.pairwise(refining):
        assert (after == done + 1 and of == total) or after == 1
    # each target's advance comes after its batches
    order = [kind for kind, _ in seen.calls]
    assert order.index("advance") > order.index("batch")


def test_design_shows_targets_done_of_total_and_one_line_per_result(tmp_path, capsys):
    assert main(["design", str(scene(tmp_path, 2)), "--out", str(tmp_path / "out")]) in (0, 1)
    err = capsys.readouterr().err
    assert "design: targets 0/2 (0 %)" in err and "design: targets 2/2 (100 %)" in err
    assert err.rstrip().endswith("design: writing the report")
    assert len(re.findall(r"design: result \d/2 ", err)) == 2


def test_unitcell_sweep_chunks_are_a_stage_of_the_display():
    import io

    from dpfexplore.cli.unitcell import _chunks

    stream = io.StringIO()
    with Progress("unitcell sweep", stream, heartbeat=False) as display:
        progress = _chunks(display)
        progress(1, 4)  # the first report opens the stage, with what is done already
        progress(4, 4)
    said = [line[9:] for line in stream.getvalue().splitlines()]
    assert said[0] == "unitcell sweep: chunks 1/4 (25 %)"
    assert said[-1].startswith("unitcell sweep: chunks 4/4 (100 %)")


def test_a_benchmark_runs_inside_a_display_that_speaks_only_when_silent():
    from dpfexplore.cli.bench import _with_progress
    from dpfexplore.io.progress import active

    seen = []

    def handler(args):
        seen.append((active().what, active().boundaries))
        return 7

    assert _with_progress("statics", handler)(None) == 7
    assert seen == [("benchmark statics", False)] and active() is None
