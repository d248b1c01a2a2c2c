"""The map's image: every kept row's tip binned into the pixels of the visible range, coloured.

Rasterized on the server (the kernels of :mod:`dpfexplore._kernels.raster.binning`: one pass
over the rows), so that the browser receives one image of ``width x height`` pixels whatever the
number of rows: 10^6 rows bin in about 10 ms on one core. Two ways to colour a pixel:

* by a **value** (stiffness, curvature, energy, ...): the mean of the column over the pixel's
  rows, through a perceptually uniform colour map (viridis) between the kept rows' 1st and 99th
  percentiles; rows whose value is NaN count for the density only;
* by a **category** (``N``, state, status): the colours of the pixel's categories mixed in
  proportion to their rows (Datashader's ``count_cat`` shading).

In both, a pixel's opacity grows with the logarithm of its row count, from 40 % for one row to
100 % for the densest pixel, so that dense and sparse regions both stay visible; empty pixels
are transparent.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["CATEGORY_COLOURS", "Raster", "category_colours", "rasterize"]

#: Colours of categories in order (Tableau 10, then its lighter half), as RGB bytes.
CATEGORY_COLOURS = np.array(
    [
        (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
        (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
        (174, 199, 232), (255, 187, 120), (152, 223, 138), (255, 152, 150), (197, 176, 213),
        (196, 156, 148), (247, 182, 210), (199, 199, 199), (219, 219, 141), (158, 218, 229),
    ],
    dtype=np.float64,
)  # fmt: skip
#: Opacity of a pixel holding one row (the densest holds 1).
_MIN_ALPHA = 0.4


@dataclass(frozen=True)
class Raster:
    """One rendered map image.

    Attributes
    ----------
    image : ndarray of uint32, shape (height, width)
        RGBA pixels packed little-endian (Bokeh's ``image_rgba``), row 0 at the bottom.
    x_range, y_range : (float, float), mm
        The data range the image covers.
    rows : int
        Rows whose tip falls inside the range.
    low, high : float
        Colour-map limits of a value colouring (NaN for a category colouring).
    """

    image: NDArray[np.uint32]
    x_range: tuple[float, float]
    y_range: tuple[float, float]
    rows: int
    low: float = np.nan
    high: float = np.nan


def category_colours(count: int) -> NDArray[np.float64]:
    """``count`` RGB colours (bytes as floats), cycling through :data:`CATEGORY_COLOURS`."""
    return CATEGORY_COLOURS[np.arange(count) % len(CATEGORY_COLOURS)]


@functools.cache
def _viridis() -> NDArray[np.float64]:
    from matplotlib import colormaps

    return colormaps["viridis"](np.linspace(0.0, 1.0, 256))[:, :3] * 255.0


def rasterize(
    tip: NDArray[np.float64],
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    width: int,
    height: int,
    *,
    values: NDArray[np.float64] | None = None,
    categories: NDArray[np.integer] | None = None,
    limits: tuple[float, float] | None = None,
) -> Raster:
    """Bin ``tip`` into ``width x height`` pixels over the ranges and colour them.

    Parameters
    ----------
    tip : ndarray of shape (n, 2), mm
        The rows to draw (already filtered).
    x_range, y_range : (float, float), mm
        Data range of the image (low < high).
    width, height : int
        Pixels.
    values : ndarray of shape (n,), optional
        Colour by the pixel's mean value.
    categories : ndarray of int, shape (n,), optional
        Colour by category (codes ``0..K-1``); exclusive with ``values``. Neither: by density.
    limits : (float, float), optional
        Colour-map limits of ``values`` (default: their 1st and 99th percentiles).

    Raises
    ------
    ValueError
        An empty or reversed range, a non-positive size.
    """
    if not (x_range[1] > x_range[0] and y_range[1] > y_range[0]):
        raise ValueError(f"range x {x_range}, y {y_range}: need low < high")
    if width < 1 or height < 1:
        raise ValueError(f"image size {width} x {height}: need at least one pixel")
    from .._kernels.raster.binning import bin_categories, bin_values

    size = width * height
    tip = np.ascontiguousarray(tip, dtype=np.float64)
    frame = np.array(
        [
            x_range[0],
            y_range[0],
            width / (x_range[1] - x_range[0]),
            height / (y_range[1] - y_range[0]),
            width,
            height,
        ],
        dtype=np.float64,
    )
    low = high = np.nan
    if values is None:
        codes = np.zeros(tip.shape[0], dtype=np.int64) if categories is None else categories
        codes = np.ascontiguousarray(codes, dtype=np.int64)
        k = int(codes.max()) + 1 if codes.size else 1
        count, rgb = bin_categories(tip, codes, category_colours(k), frame)
        rgb /= np.maximum(count, 1.0)[:, None]
    else:
        v = np.ascontiguousarray(values, dtype=np.float64)
        if limits is None:
            finite = v[np.isfinite(v)]
            limits = tuple(np.percentile(finite, [1.0, 99.0])) if finite.size else (0.0, 1.0)
        low, high = float(limits[0]), float(limits[1])
        count, n, sums = bin_values(tip, v, frame)
        mean = sums / np.maximum(n, 1.0)
        scaled = (mean - low) / (high - low) if high > low else np.full(size, 0.5)
        lut = np.clip(np.round(scaled * 255.0), 0, 255).astype(np.int64)
        rgb = _viridis()[lut]
        rgb[n == 0] = 150.0  # rows without a value: grey
    alpha = np.zeros(size)
    occupied = count > 0
    if occupied.any():
        top = np.log1p(count.max())
        alpha[occupied] = _MIN_ALPHA + (1.0 - _MIN_ALPHA) * np.log1p(count[occupied]) / top
    rgba = np.empty((size, 4), dtype=np.uint8)
    rgba[:, :3] = np.clip(np.round(rgb), 0, 255)
    rgba[:, 3] = np.round(alpha * 255.0)
    image = rgba.view(np.uint32).reshape(height, width)
    return Raster(
        image=image,
        x_range=(float(x_range[0]), float(x_range[1])),
        y_range=(float(y_range[0]), float(y_range[1])),
        rows=int(count.sum()),
        low=low,
        high=high,
    )
