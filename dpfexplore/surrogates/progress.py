"""How a surrogate fit reports its progress: a bar on a terminal, lines otherwise.

A fit is a known number of steps (each status classifier, each regressor, the exact model's
errors, the timing); :func:`~.fit.fit_surrogates` tells its progress when each step begins and
ends. :func:`fit_progress` picks the display as the sweep's CLI does
(:mod:`dpfexplore.sweep.progress`): a tqdm bar on ``stream`` when it is a terminal (the step
under way as its description, each finished step's line above it), else one line per step to
a callable or the module logger. Output problems never stop a fit.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from typing import IO, Protocol, runtime_checkable

__all__ = ["BarProgress", "FitProgress", "LineProgress", "fit_progress"]

logger = logging.getLogger("dpfexplore.surrogates.fit")  # the name users filter on


@runtime_checkable
class FitProgress(Protocol):
    """Receives a surrogate fit's progress."""

    def start(self, total: int) -> None:
        """Called once, with the number of steps."""

    def begin(self, text: str) -> None:
        """A step begins (``"fitting mlp"``)."""

    def step(self, line: str) -> None:
        """A step ended; ``line`` says what it found."""

    def note(self, line: str) -> None:
        """A line that ends no step (the split)."""

    def close(self) -> None:
        """Called once at the end (also after an error)."""


class LineProgress:
    """One line per step and note, to ``emit`` (default: the logger, INFO)."""

    def __init__(self, emit: Callable[[str], None] | None = None) -> None:
        self.emit = emit or logger.info
        self.total = self.done = 0

    def start(self, total: int) -> None:
        """Note the number of steps."""
        self.total, self.done = total, 0

    def begin(self, text: str) -> None:
        """Nothing: the step's line comes when it ends."""

    def step(self, line: str) -> None:
        """Write the step's line."""
        self.done += 1
        self.emit(line)

    def note(self, line: str) -> None:
        """Write the line."""
        self.emit(line)

    def close(self) -> None:
        """Nothing to release."""


class BarProgress:
    """A tqdm bar over the steps on ``stream``; finished steps' lines are written above it."""

    def __init__(self, stream: IO[str] | None = None) -> None:
        self.stream = stream or sys.stderr
        self.bar = None

    def start(self, total: int) -> None:
        """Open the bar."""
        from tqdm import tqdm

        self.bar = tqdm(
            total=total, unit="step", dynamic_ncols=True, file=self.stream, desc="surrogate fit"
        )

    def begin(self, text: str) -> None:
        """Show the step under way."""
        if self.bar is not None:
            self.bar.set_description_str(text)

    def step(self, line: str) -> None:
        """Write the line above the bar and advance it."""
        if self.bar is not None:
            self.bar.write(line, file=self.stream)
            self.bar.update(1)

    def note(self, line: str) -> None:
        """Write the line above the bar."""
        if self.bar is not None:
            self.bar.write(line, file=self.stream)

    def close(self) -> None:
        """Close the bar."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def fit_progress(
    progress: FitProgress | Callable[[str], None] | None = None, *, stream: IO[str] | None = None
) -> FitProgress:
    """The display of a fit's progress.

    Parameters
    ----------
    progress : FitProgress, callable or None
        A :class:`FitProgress` is used as it is; a callable receives one line per step (and
        per note); None: a bar if ``stream`` is a terminal, else lines to the logger.
    stream : file, optional
        Where the bar goes (default: standard error).
    """
    if isinstance(progress, FitProgress):
        return progress
    if progress is not None:
        return LineProgress(progress)
    stream = stream or sys.stderr
    isatty = getattr(stream, "isatty", None)
    if isatty is not None and isatty():
        return BarProgress(stream)
    return LineProgress()
