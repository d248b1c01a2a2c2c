"""A surrogate fit tells its progress: one line per step, or a bar on a terminal."""

from __future__ import annotations

import io

import pytest
from sweep_helpers import make_job

from dpfexplore.surrogates.data import load_training_data
from dpfexplore.surrogates.fit import fit_surrogates
from dpfexplore.surrogates.progress import BarProgress, LineProgress, fit_progress
from dpfexplore.sweep.driver import run_sweep

FAST = {"gbt": {"max_iter": 20}, "classifier": {"max_iter": 20}}


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("fit-progress") / "sweep"
    run_sweep(make_job(**{"job.samples_per_n": 30, "compute.states": "sequential"}), root)
    return load_training_data(root, ("tip_x", "tip_y"))


class Recorder:
    """A FitProgress that keeps every call."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def start(self, total):
        self.calls.append(("start", total))

    def begin(self, text):
        self.calls.append(("begin", text))

    def step(self, line):
        self.calls.append(("step", line))

    def note(self, line):
        self.calls.append(("note", line))

    def close(self):
        self.calls.append(("close", None))


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_every_step_is_begun_and_ended_and_counted(data):
    rec = Recorder()
    fit_surrogates(
        data, kinds=["knn", "gbt"], classifier_kind="gbt", params=FAST, timing=True, progress=rec
    )
    kinds = [kind for kind, _ in rec.calls]
    assert kinds[0] == "start" and kinds[-1] == "close" and kinds.count("close") == 1
    total = rec.calls[0][1]
    # one classifier, two regressors, the exact model, the timing
    assert total == 5 == kinds.count("step") == kinds.count("begin")
    begun = [text for kind, text in rec.calls if kind == "begin"]
    assert begun == [
        "fitting classifier (gbt)",
        "fitting knn",
        "fitting gbt",
        "exact model on the held-out designs",
        "timing on one thread",
    ]
    # each step ends before the next begins
    for i, (kind, _) in enumerate(rec.calls):
        if kind == "begin":
            assert next(k for k, _ in rec.calls[i + 1 :] if k in ("begin", "step")) == "step"
    assert rec.calls[1][0] == "note" and rec.calls[1][1].startswith("split by design:")


def test_a_callable_gets_one_line_per_step_and_note(data):
    lines: list[str] = []
    fit_surrogates(data, kinds=["knn"], params=FAST, timing=False, progress=lines.append)
    assert lines[0].startswith("split by design:")
    assert any(line.startswith("classifier (gbt): held-out accuracy") for line in lines)
    assert any(line.startswith("knn: fitted in") for line in lines)
    assert lines[-1].startswith("exact model: status agreement")
    # classifiers gbt and chain (the default), knn, the exact model: 4 steps and the split
    assert len(lines) == 5


def test_the_progress_is_closed_when_the_fit_fails(data):
    rec = Recorder()
    with pytest.raises(ValueError, match="kind 'nope'"):
        fit_surrogates(data, kinds=["nope"], progress=rec)
    assert rec.calls == [("close", None)]


def test_a_bar_on_a_terminal_lines_otherwise(caplog):
    assert isinstance(fit_progress(None, stream=Terminal()), BarProgress)
    assert isinstance(fit_progress(None, stream=io.StringIO()), LineProgress)
    given = LineProgress()
    assert fit_progress(given) is given
    # without a terminal, the lines go to the logger
    shown = fit_progress(None, stream=io.StringIO())
    with caplog.at_level("INFO", logger="dpfexplore.surrogates.fit"):
        shown.start(1)
        shown.begin("fitting knn")
        shown.step("knn: fitted")
        shown.close()
    assert [r.getMessage() for r in caplog.records] == ["knn: fitted"]


def test_the_bar_shows_the_step_under_way_and_the_lines_above_it():
    stream = Terminal()
    bar = fit_progress(None, stream=stream)
    bar.start(2)
    bar.note("split by design: 10 training designs")
    bar.begin("fitting knn")
    bar.step("knn: fitted in 0.1 s")
    assert bar.bar.n == 1 and bar.bar.total == 2
    assert bar.bar.desc.startswith("fitting knn")
    bar.close()
    text = stream.getvalue()
    assert "split by design: 10 training designs\n" in text
    assert "knn: fitted in 0.1 s\n" in text
    assert "1/2" in text
