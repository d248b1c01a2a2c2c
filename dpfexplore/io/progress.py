"""What a long command tells its user while it works: the one progress display of the package.

A command's work is a sequence of *stages* (``"compiling the states kernels, group 1/2"``,
``"target 2/5 (46, 32)"``, ``"designs"``), each with a count done out of a total when it has one.
:class:`Progress` shows them on a stream:

* on a terminal, one updating line (a tqdm bar): the stage, done/total, the rate and an estimate
  of the time left; lines that must stay (:meth:`Progress.note`) are written above it;
* otherwise (a pipe, a log file), plain lines ``HH:MM:SS NAME: ...`` (or log records): every
  note, a line when a stage begins and when it reaches its total, and the stage's state in
  between at most once every ``interval`` seconds.

A stage between two updates (a Numba compilation, one long evaluation) is not silent: a
heartbeat thread calls :meth:`Progress.tick` every ``interval / 8`` s, which refreshes the bar
(its clock keeps running) or writes the stage's line once ``interval`` seconds have passed
without one. Stage and update calls cost a lock and a clock reading; lines are written only at
the rate above, so a stage may report every iteration.

:func:`active` is the innermost display open in this process (a ``with Progress(...)`` block):
code far below the command (the compilation watcher of :mod:`dpfexplore.solvers.compilation`)
reports its stages there instead of opening a second display on the same stream.

Output problems (a closed pipe, a vanished terminal) never stop the work: the display goes
quiet.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import IO

__all__ = ["Progress", "active", "duration"]

#: Displays open in this process, innermost last (:func:`active`).
_OPEN: list[Progress] = []


def active() -> Progress | None:
    """The innermost display open in this process (``with Progress(...)``), or None."""
    return _OPEN[-1] if _OPEN else None


def duration(seconds: float) -> str:
    """``seconds`` as a person reads it: ``"8 s"``, ``"2 min 05 s"``, ``"1 h 03 min"``."""
    seconds = max(round(seconds), 0)
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


def _is_terminal(stream: IO[str]) -> bool:
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty is not None and isatty())
    except (OSError, ValueError):
        return False


class Progress:
    """Stages of a command's work with done/total and an estimate, on a terminal or as lines.

    Parameters
    ----------
    name : str
        What the lines are prefixed with (``"sweep"``, ``"design"``).
    stream : file, optional
        Where to write (default: standard error, looked up when writing).
    bar : bool, optional
        Force the terminal bar (True) or plain lines (False); default: a bar when ``stream``
        is a terminal.
    interval : float
        Seconds, at least, between two plain lines of stage state (notes are never held back),
        and at most between two lines while a stage runs. Default 4 s.
    clock : callable
        Seconds on a monotonic clock (tests pass a fake one).
    heartbeat : bool
        Start the thread that calls :meth:`tick` while a stage runs (tests call it themselves).
    emit : callable, optional
        Receives each plain line instead of ``stream`` (no bar then): a logger's method, for
        the library's default of log records.
    boundaries : bool
        Plain lines also when a stage begins and when it reaches its total (default); False
        when the caller's notes already say so (a surrogate fit's one line per step).
    """

    def __init__(
        self,
        name: str,
        stream: IO[str] | None = None,
        *,
        bar: bool | None = None,
        interval: float = 4.0,
        clock: Callable[[], float] = time.monotonic,
        heartbeat: bool = True,
        emit: Callable[[str], None] | None = None,
        boundaries: bool = True,
    ) -> None:
        self.name = name
        self._stream = stream
        self.emit = emit
        self.boundaries = boundaries
        if emit is not None:
            bar = False
        self.use_bar = _is_terminal(self.stream) if bar is None else bar
        self.interval = float(interval)
        self.clock = clock
        self.heartbeat = heartbeat
        self.bar = None  # the tqdm bar of the stage under way (terminal only)
        self.what: str | None = None  # the stage under way
        self.total: int | None = None
        self.done = self._done_at_start = 0
        self.unit = ""
        self.detail = ""
        self.busy: Callable[[], bool] | None = None
        self._cpu_started: float | None = None
        self._started = self._last_line = clock()
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._quiet = False  # the stream failed: write nothing more

    @property
    def opened(self) -> bool:
        """Whether the display is open as a ``with`` block (:func:`active` may return it)."""
        return self in _OPEN

    @property
    def stream(self) -> IO[str]:
        """Where the display writes."""
        return self._stream if self._stream is not None else sys.stderr

    # ------------------------------------------------------------------ stages

    def stage(
        self,
        what: str,
        total: int | None = None,
        *,
        done: int = 0,
        unit: str = "",
        busy: Callable[[], bool] | None = None,
        cpu: bool = False,
    ) -> None:
        """Begin a stage: ``what`` it is, ``total`` steps (None: unknown), ``done`` already.

        ``busy``, when given, says whether the stage is at work right now; the heartbeat stays
        quiet while it answers False (a compilation watcher between two compilations). ``cpu``:
        the lines also say the seconds of CPU the process spent in the stage (a compilation,
        whose expected cost is quoted in CPU seconds).
        """
        with self._lock:
            self._close_bar()
            self.what, self.total, self.unit, self.busy = what, total, unit, busy
            self.done = self._done_at_start = done
            self.detail = ""
            self._started = self.clock()
            self._cpu_started = time.process_time() if cpu else None
            if self.use_bar:
                self._open_bar()
            elif self.boundaries:
                self._write_state()
            self._start_heartbeat()

    def update(self, done: int | None = None, *, advance: int = 0, detail: str | None = None):
        """The stage reached ``done`` steps (or ``advance`` more); ``detail`` says where."""
        with self._lock:
            if self.what is None:
                return
            previous = self.done
            self.done = (self.done if done is None else done) + advance
            if detail is not None:
                self.detail = detail
            if self.bar is not None:
                self._bar_call(self._bar_show, self.done - previous)
            elif not self.use_bar:
                finished = self.total is not None and self.done >= self.total > previous
                if self.clock() - self._last_line >= self.interval or (
                    finished and self.boundaries
                ):
                    self._write_state()

    def note(self, line: str) -> None:
        """Write ``line`` now (above the bar on a terminal): what must stay in the output."""
        with self._lock:
            if self.bar is not None:
                self._bar_call(lambda: self.bar.write(line, file=self.stream))
            else:
                self._write(line)

    def end_stage(self) -> None:
        """The stage is over (its bar closes; nothing is shown until the next stage)."""
        with self._lock:
            self._close_bar()
            self.what = None

    def tick(self) -> None:
        """Called by the heartbeat: keep the display alive while a stage runs."""
        with self._lock:
            if self.what is None or (self.busy is not None and not self.busy()):
                return
            if self.bar is not None:
                self._bar_call(self.bar.refresh)
            elif not self.use_bar and self.clock() - self._last_line >= self.interval:
                self._write_state()

    def close(self) -> None:
        """End the display: the bar closes, the heartbeat stops."""
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        with self._lock:
            self._close_bar()
            self.what = None
        if self in _OPEN:
            _OPEN.remove(self)

    def __enter__(self) -> Progress:
        _OPEN.append(self)
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ text

    def state_text(self) -> str:
        """The stage under way as one line: done/total, rate and time left (ETA), time so far."""
        elapsed = self.clock() - self._started
        parts = [self.what or ""]
        if self.total is not None:
            percent = 100.0 * self.done / max(self.total, 1)
            parts[0] += f" {self.done}/{self.total} ({percent:.0f} %)"
            counted = self.done - self._done_at_start
            if counted > 0 and elapsed > 0:
                rate = counted / elapsed
                if self.unit:
                    shown = f"{rate:.0f}" if rate >= 10 else f"{rate:.2g}"
                    parts.append(f"{shown} {self.unit}s/s")
                parts.append(f"ETA {duration((self.total - self.done) / rate)}")
        if self.detail:
            parts.append(self.detail)
        if elapsed >= 1:
            cpu = self._cpu_started
            used = "" if cpu is None else f" ({time.process_time() - cpu:.0f} s of CPU)"
            parts.append(f"{duration(elapsed)} so far{used}")
        return ", ".join(p for p in parts if p)

    def _write_state(self) -> None:
        self._write(self.state_text())

    def _write(self, line: str) -> None:
        self._last_line = self.clock()
        if self._quiet:
            return
        try:
            if self.emit is not None:
                self.emit(line)
                return
            self.stream.write(f"{time.strftime('%H:%M:%S')} {self.name}: {line}\n")
            self.stream.flush()
        except (OSError, ValueError):
            self._quiet = True

    # ------------------------------------------------------------------ terminal bar

    def _open_bar(self) -> None:
        if self._quiet:
            return
        from tqdm import tqdm

        known = self.total is not None
        try:
            self.bar = tqdm(
                total=self.total,
                initial=self.done,
                desc=f"{self.name}: {self.what}",
                unit=f" {self.unit}" if self.unit else "it",
                unit_scale=bool(self.unit) and known and self.total >= 10_000,
                dynamic_ncols=True,
                file=self.stream,
                bar_format=None if known else "{desc}: {elapsed}{postfix}",
                leave=self.boundaries,  # a stage that tells no boundaries leaves no line
            )
        except (OSError, ValueError):
            self.bar, self._quiet = None, True

    def _bar_show(self, steps: int) -> None:
        # tqdm redraws on update at most every 0.1 s; a detail alone waits for the heartbeat's
        # refresh (every 0.5 s), so a loop may report every iteration
        self.bar.set_postfix_str(self.detail, refresh=False)
        if steps:
            self.bar.update(steps)

    def _bar_call(self, call, *args) -> None:
        try:
            call(*args)
        except (OSError, ValueError):  # the terminal went away: go on without a bar
            self.bar, self._quiet = None, True

    def _close_bar(self) -> None:
        if self.bar is not None:
            self._bar_call(self.bar.close)
            self.bar = None

    # ------------------------------------------------------------------ heartbeat

    def _start_heartbeat(self) -> None:
        if not self.heartbeat or self._thread is not None or self._stop.is_set():
            return
        period = min(self.interval / 8.0, 0.5)

        def beat() -> None:
            while not self._stop.wait(period):
                self.tick()

        self._thread = threading.Thread(target=beat, name=f"{self.name} progress", daemon=True)
        self._thread.start()
