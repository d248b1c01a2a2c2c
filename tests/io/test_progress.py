"""The one progress display: a bar on a terminal, timed plain lines otherwise, a fake clock."""

from __future__ import annotations

import io
import itertools
import re

from dpfexplore.io.progress import Progress, active, duration


class Clock:
    """A clock the test moves by hand."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def lines(stream: io.StringIO) -> list[str]:
    """The plain lines written, without their ``HH:MM:SS `` time."""
    out = []
    for line in stream.getvalue().splitlines():
        assert re.match(r"^\d\d:\d\d:\d\d ", line), line
        out.append(line[9:])
    return out


def test_piped_lines_at_most_every_interval_and_never_silent_longer():
    clock, stream = Clock(), io.StringIO()
    shown = Progress("sweep", stream, interval=4.0, clock=clock, heartbeat=False)
    assert not shown.use_bar  # a StringIO is not a terminal
    shown.stage("designs", 100, unit="design")
    written = [clock.now]  # the stage's first line
    for _ in range(1, 100):
        clock.now += 0.25  # a chunk every 0.25 s: 99 updates ...
        shown.update(advance=1)
        shown.tick()
        if len(lines(stream)) > len(written):
            written.append(clock.now)
    # ... but a line only every 4 s (and the last one when the total is reached)
    gaps = [b - a for a, b in itertools.pairwise(written)]
    assert len(written) == len(lines(stream)) and all(g >= 4.0 - 1e-9 for g in gaps[:-1])
    shown.update(advance=1)  # 100/100: the stage's end is always told
    said = lines(stream)
    assert said[0] == "sweep: designs 0/100 (0 %)"
    assert said[-1].startswith("sweep: designs 100/100 (100 %)")
    # 16 designs in 4 s: 84 left at 4 designs/s
    assert said[1] == "sweep: designs 16/100 (16 %), 4 designs/s, ETA 21 s, 4 s so far"
    assert len(said) == 1 + 6 + 1  # the start, one every 4 s of the 24.75 s, the end


def test_the_heartbeat_speaks_when_updates_stop_and_only_while_busy():
    clock, stream = Clock(), io.StringIO()
    busy = [True]
    shown = Progress("states", stream, interval=4.0, clock=clock, heartbeat=False)
    shown.stage("compiling 1/2: states kernels", busy=lambda: busy[0])
    for _ in range(12):  # 12 s of one long call, ticked every 0.5 s
        clock.now += 0.5
        shown.tick()
        clock.now += 0.5
        shown.tick()
    said = lines(stream)
    assert said == [
        "states: compiling 1/2: states kernels",
        "states: compiling 1/2: states kernels, 4 s so far",
        "states: compiling 1/2: states kernels, 8 s so far",
        "states: compiling 1/2: states kernels, 12 s so far",
    ]
    busy[0] = False  # between two compilations: nothing to say
    clock.now += 30
    shown.tick()
    shown.note("done")  # a note is never held back
    assert lines(stream)[4:] == ["states: done"]
    shown.end_stage()
    clock.now += 30
    shown.tick()
    assert len(lines(stream)) == 5


def test_the_bar_on_a_terminal_counts_refreshes_and_keeps_notes():
    clock, stream = Clock(), Terminal()
    with Progress("design", stream, clock=clock, heartbeat=False) as shown:
        assert shown.use_bar and active() is shown
        shown.stage("targets", 5, unit="target")
        shown.update(advance=2, detail="target 3/5: refining 12/60")
        shown.note("result 2/5 (25, 20): objective 2.8e-10")
        shown.tick()  # the bar's clock keeps running between updates
        assert shown.bar.n == 2 and shown.bar.total == 5
        assert shown.bar.desc == "design: targets"
    assert active() is None and shown.bar is None
    text = stream.getvalue()
    assert "result 2/5 (25, 20): objective 2.8e-10\n" in text
    assert "2/5" in text and "target 3/5: refining 12/60" in text


def test_log_records_instead_of_a_stream_and_a_broken_stream_goes_quiet():
    said = []
    shown = Progress("fit", emit=said.append, clock=Clock(), heartbeat=False, boundaries=False)
    shown.stage("steps", 2)
    shown.note("knn: fitted")
    shown.update(advance=2)
    assert said == ["knn: fitted"]  # no boundary lines: the notes say it

    class Broken(io.StringIO):
        def write(self, text):
            raise OSError("closed pipe")

    quiet = Progress("sweep", Broken(), clock=Clock(), heartbeat=False)
    quiet.stage("designs", 3)  # does not raise; nothing more is tried
    quiet.update(advance=3)
    quiet.note("x")
    quiet.close()


def test_duration_reads_like_a_person_writes_it():
    assert [duration(s) for s in (0.4, 8, 59.6, 125, 3780)] == [
        "0 s",
        "8 s",
        "1 min 00 s",
        "2 min 05 s",
        "1 h 03 min",
    ]
