"""How a surrogate fit reports its progress: a bar on a terminal, lines otherwise.

A fit is a known number of steps (each status classifier, each regressor, the exact model's
errors, the timing); :func:`~.fit.fit_surrogates` tells its progress when each step begins and
ends. :func:`fit_progress` picks the display (:class:`dpfexplore.io.progress.Progress`, the
package's one): a tqdm bar on ``stream`` when it is a terminal (the step under way as its
description, each finished step's line above it), else one line per step to a callable or the
module logger, and a line of the step under way when one runs longer than a few seconds.
Output problems never stop a fit.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from typing import IO, Protocol, runtime_checkable

from ..io.progress import Progress as Display

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


class _DisplayProgress:
    """A fit's steps as stages of a display (:class:`dpfexplore.io.progress.Progress`)."""

    display: Display

    def start(self, total: int) -> None:
        """Note the number of steps."""
        self.display.stage("steps", total, unit="step")

    def begin(self, text: str) -> None:
        """Show the step under way."""
        self.display.update(detail=text)

    def step(self, line: str) -> None:
        """Write the step's line and count the step."""
        self.display.note(line)
        self.display.update(advance=1)

    def note(self, line: str) -> None:
        """Write the line."""
        self.display.note(line)

    def close(self) -> None:
        """End the display."""
        self.display.close()

    @property
    def total(self) -> int:
        """Steps of the fit."""
        return self.display.total or 0

    @property
    def done(self) -> int:
        """Steps done."""
        return self.display.done


class LineProgress(_DisplayProgress):
    """One line per step and note, to ``emit`` (default: the logger, INFO).

    A step longer than the display's interval (4 s) adds a line of the step under way and
    its time so far, every interval.
    """

    def __init__(self, emit: Callable[[str], None] | None = None) -> None:
        self.emit = emit or logger.info
        self.display = Display("surrogate fit", emit=self.emit, boundaries=False)


class BarProgress(_DisplayProgress):
    """A tqdm bar over the steps on ``stream``; finished steps' lines are written above it."""

    def __init__(self, stream: IO[str] | None = None) -> None:
        self.stream = stream or sys.stderr
        self.display = Display("surrogate fit", self.stream, bar=True)

    @property
    def bar(self):
        """The tqdm bar while the fit runs, else None."""
        return self.display.bar

    def begin(self, text: str) -> None:
        """Show the step under way as the bar's description."""
        self.display.update(detail=text)
        if self.bar is not None:
            self.bar.set_description_str(text)


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
