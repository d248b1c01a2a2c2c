"""What one browser tab of the explorer is looking at, and what its gestures do (no Bokeh here).

:class:`ExploreSession` holds a page's state (filters, colouring, the visible range, the last
target and its designs) over a shared :class:`~.data.ExploreData` and
:class:`~.designs.DesignFinder`, and has one method per gesture: :meth:`set_filters`,
:meth:`set_colour`, :meth:`render` (a zoom or pan), :meth:`tap` (a click on the map or a typed
target). The Bokeh page (:mod:`.page`) only forwards its widgets' events here and draws what
comes back, so every callback is testable in Python without a browser.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..model.status import Status
from .data import COLOUR_CATEGORIES, ExploreData, Filters
from .designs import DesignFinder, Pick
from .raster import Raster, rasterize

__all__ = ["ExploreSession", "TapResult"]

#: Margin around the tips' extent in the first view, as a share of the extent.
_MARGIN = 0.05


@dataclass(frozen=True)
class TapResult:
    """The answer to a click or a typed target.

    Attributes
    ----------
    target : (float, float), mm
    picks : list of Pick
        Best first; empty when ``error`` says why.
    seconds : float
        Lookup, refinement and verification.
    error : str or None
        One line when no design could be given (no ``ok`` row passes the filters, ...).
    """

    target: tuple[float, float]
    picks: list[Pick] = field(default_factory=list)
    seconds: float = 0.0
    error: str | None = None


class ExploreSession:
    """One page's view of a dataset.

    Parameters
    ----------
    data : ExploreData
    finder : DesignFinder
        Shared by the sessions of one server (it holds the lookup index).
    width, height : int
        Pixels of the map image.
    """

    def __init__(
        self, data: ExploreData, finder: DesignFinder, *, width: int = 720, height: int = 560
    ) -> None:
        self.data = data
        self.finder = finder
        self.width, self.height = int(width), int(height)
        self.filters = Filters()
        self.keep = np.ones(len(data), dtype=bool)
        self.colour = "n_units"
        self.x_range, self.y_range = self.full_range()
        self.last_tap: TapResult | None = None
        self.render_seconds = 0.0
        self._drawn: tuple | None = None

    # ------------------------------------------------------------------ state

    def full_range(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Ranges (mm) holding every finite tip with a margin, with equal mm per pixel."""
        tip = self.data.tip[np.all(np.isfinite(self.data.tip), axis=1)]
        if tip.size == 0:
            return (-1.0, 1.0), (-1.0, 1.0)
        low, high = tip.min(axis=0), tip.max(axis=0)
        span = np.maximum(high - low, 1e-6) * (1 + 2 * _MARGIN)
        centre = (low + high) / 2
        # equal aspect: mm per pixel the same along x and y
        per_pixel = max(span[0] / self.width, span[1] / self.height)
        half = np.array([self.width, self.height]) * per_pixel / 2
        return (
            (float(centre[0] - half[0]), float(centre[0] + half[0])),
            (float(centre[1] - half[1]), float(centre[1] + half[1])),
        )

    @property
    def count(self) -> int:
        """Rows passing the filters."""
        return int(np.count_nonzero(self.keep))

    def counts(self) -> dict[str, dict]:
        """Rows passing the filters per value of N, material and status (the filter labels)."""
        keep = self.keep
        return {
            "n_units": {
                n: int(np.count_nonzero(keep & (self.data.n_units == n)))
                for n in self.data.n_values
            },
            "material": {
                m: int(
                    np.count_nonzero(keep & (self.data.material == self.data.materials.index(m)))
                )
                for m in self.data.materials_present
            },
            "status": {
                s: int(np.count_nonzero(keep & (self.data.status == int(Status[s.upper()]))))
                for s in self.data.status_labels
            },
        }

    def set_filters(self, filters: Filters) -> int:
        """Apply ``filters``; returns the rows passing them (ValueError for a bad filter)."""
        keep = self.data.mask(filters)
        self.filters, self.keep = filters, keep
        self._drawn = None
        return self.count

    def colour_options(self) -> list[str]:
        """Columns the map can be coloured by: categories, then the numeric outputs."""
        return [*COLOUR_CATEGORIES, *self.data.columns]

    def set_colour(self, name: str) -> None:
        """Colour the map by ``name`` (one of :meth:`colour_options`)."""
        if name not in self.colour_options():
            raise ValueError(f"colour {name!r}: one of {', '.join(self.colour_options())}")
        self.colour = name
        self._drawn = None

    # ------------------------------------------------------------------ gestures

    def render(
        self,
        x_range: tuple[float, float] | None = None,
        y_range: tuple[float, float] | None = None,
    ) -> Raster:
        """The map image of the kept rows over the ranges (the current ones by default)."""
        start = time.perf_counter()
        if x_range is not None:
            self.x_range = (float(x_range[0]), float(x_range[1]))
        if y_range is not None:
            self.y_range = (float(y_range[0]), float(y_range[1]))
        if self._drawn is None:  # the kept rows' arrays, until the filters or the colour change
            self._drawn = self._drawn_arrays()
        tip, values, categories, limits = self._drawn
        raster = rasterize(
            tip,
            self.x_range,
            self.y_range,
            self.width,
            self.height,
            values=values,
            categories=categories,
            limits=limits,
        )
        self.render_seconds = time.perf_counter() - start
        return raster

    def _drawn_arrays(self):
        """The kept rows' tips and colour column, and the colour limits."""
        rows = np.flatnonzero(self.keep)
        tip = self.data.tip[rows]
        values = categories = limits = None
        if self.colour == "n_units":
            categories = self.data.n_units[rows] - min(self.data.n_values)
        elif self.colour == "state":
            categories = self.data.requested[rows]
        elif self.colour == "status":
            categories = self.data.status[rows].astype(np.int64)
        else:
            values = self.data.columns[self.colour][rows]
            limits = self._limits(self.colour)
        return tip, values, categories, limits

    def _limits(self, name: str) -> tuple[float, float]:
        """Colour limits of a column over the kept rows: 1st and 99th percentiles."""
        values = self.data.columns[name][self.keep]
        finite = values[np.isfinite(values)]
        if finite.size == 0:
            return 0.0, 1.0
        low, high = np.percentile(finite, [1.0, 99.0])
        return float(low), float(high)

    def tap(self, x: float, y: float) -> TapResult:
        """The verified designs nearest to the tip ``(x, y)`` (mm) under the filters."""
        target = (float(x), float(y))
        try:
            picks, seconds = self.finder.find(target, self.keep)
        except ValueError as exc:
            self.last_tap = TapResult(target, error=str(exc))
        else:
            self.last_tap = TapResult(target, picks, seconds)
        return self.last_tap

    def categories(self) -> list[tuple[str, int]]:
        """Legend of a category colouring: (label, colour index) pairs."""
        if self.colour == "n_units":
            low = min(self.data.n_values)
            return [(f"N = {n}", n - low) for n in self.data.n_values]
        if self.colour == "status":
            return [(label, int(Status[label.upper()])) for label in self.data.status_labels]
        if self.colour == "state":
            kept = np.unique(self.data.requested[self.keep])
            n = int(self.data.n_units.max())
            if kept.size > 12:
                return [(f"{kept.size} states (colour = state number)", -1)]
            return [(format(int(s), f"0{n}b").lstrip("0") or "0", int(s)) for s in kept]
        return []

    def kept_rows(self) -> NDArray[np.int64]:
        """Row numbers passing the filters."""
        return np.flatnonzero(self.keep)
