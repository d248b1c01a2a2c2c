"""How a sweep reports its progress: the :class:`Progress` protocol, on a display or as log lines.

Apart from :mod:`.driver` so that the CLI can define its progress display without importing the
sweep machinery (and Numba) before the arguments are even parsed.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Protocol

from ..io.progress import Progress as Display

if TYPE_CHECKING:
    from .storage.store import ChunkRecord

__all__ = ["DisplayProgress", "LogProgress", "Progress", "note"]

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


class DisplayProgress:
    """The sweep's progress on a display (:class:`dpfexplore.io.progress.Progress`).

    Designs done out of the job's, their rate and the time left: a bar on a terminal, plain
    lines otherwise; a note (what the sweep does before its first chunk) is a line of its own.
    Output problems never stop a sweep (the display goes quiet).
    """

    def __init__(self, display: Display) -> None:
        self.display = display

    def note(self, text: str) -> None:
        """A line of its own."""
        self.display.note(text)

    def start(self, total_designs: int, done_designs: int) -> None:
        """The designs' stage begins, with the designs already committed."""
        self.display.stage("designs", total_designs, done=done_designs, unit="design")

    def advance(self, record: ChunkRecord) -> None:
        """A chunk is committed."""
        self.display.update(advance=record.stop - record.start)

    def close(self) -> None:
        """The stage is over."""
        self.display.end_stage()


class LogProgress(DisplayProgress):
    """Progress as log records (INFO, ``sweep: ...``) at most every ``interval`` seconds.

    The Python API's default: the designs done, their rate and the time left, as
    :class:`DisplayProgress` shows them, to the ``dpfexplore.sweep.driver`` logger.
    """

    def __init__(self, interval: float = 10.0, log: logging.Logger = logger) -> None:
        super().__init__(
            Display("sweep", interval=interval, emit=lambda text: log.info("sweep: %s", text))
        )

    def close(self) -> None:
        """End the stage and stop the display's heartbeat."""
        self.display.close()
