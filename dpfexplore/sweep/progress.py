"""How a sweep reports its progress: the :class:`Progress` protocol and log lines.

Apart from :mod:`.driver` so that the CLI can define its progress display without importing the
sweep machinery (and Numba) before the arguments are even parsed.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from .storage.store import ChunkRecord

__all__ = ["LogProgress", "Progress", "note"]

logger = logging.getLogger("dpfexplore.sweep.driver")  # the name users filter on


class Progress(Protocol):
    """Receives the sweep's progress (the CLI shows a bar or log lines)."""

    def start(self, total_designs: int, done_designs: int) -> None:
        """Called once before the first chunk, with designs already committed."""

    def advance(self, record: ChunkRecord) -> None:
        """Called after each chunk is committed."""

    def close(self) -> None:
        """Called once at the end."""

    # Optional: ``note(text)``, told what the sweep is doing before the first chunk (compiling
    # kernels takes a minute on a cold cache).


def note(progress: Progress, text: str) -> None:
    """Tell ``progress`` what the sweep is doing (its optional ``note``), else log it."""
    show = getattr(progress, "note", None)
    if show is not None:
        show(text)  # shown by the progress itself: logging it too would print it twice
    else:
        logger.info("sweep: %s", text)


class LogProgress:
    """Progress as log lines (INFO) at most every ``interval`` seconds: done, rate, ETA.

    Subclasses change where the lines go by overriding :meth:`emit`.
    """

    def __init__(self, interval: float = 10.0, log: logging.Logger = logger) -> None:
        self.interval = interval
        self.log = log
        self.total = self.done = self.at_start = 0
        self.started = self.last = 0.0

    def emit(self, text: str) -> None:
        """Write one progress line."""
        self.log.info("sweep: %s", text)

    def start(self, total_designs: int, done_designs: int) -> None:
        """Note the totals and log the starting line."""
        self.total, self.done, self.at_start = total_designs, done_designs, done_designs
        self.started = self.last = time.perf_counter()
        self.emit(f"starting: {done_designs}/{total_designs} designs already committed")

    def advance(self, record: ChunkRecord) -> None:
        """Count a committed chunk; log a line when ``interval`` has passed or at the end."""
        self.done += record.stop - record.start
        now = time.perf_counter()
        if now - self.last >= self.interval or self.done >= self.total:
            self.last = now
            rate = (self.done - self.at_start) / max(now - self.started, 1e-9)
            eta = (self.total - self.done) / rate if rate > 0 else float("inf")
            percent = 100.0 * self.done / max(self.total, 1)
            self.emit(
                f"{self.done}/{self.total} designs ({percent:.1f} %), {rate:.0f} designs/s, "
                f"ETA {eta:.0f} s"
            )

    def close(self) -> None:
        """Nothing to release."""
