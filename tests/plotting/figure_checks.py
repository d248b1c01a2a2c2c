"""One checker of what a figure draws, applied to every figure the CLI writes.

:func:`check_figure` draws a Matplotlib figure with the Agg renderer and inspects its artists:

* no two text boxes overlap: tick labels (those matplotlib draws: ticks inside the view limits),
  axis labels, offset texts, titles, texts placed in the axes or on the figure, and each legend
  as one box;
* every text box and every legend lies inside the figure (nothing cut off at the page edge);
* no legend covers data: no vertex, marker or segment of a line drawn in data coordinates,
  no scatter point or errorbar segment, no bar, no outline or filled area of a patch (a disk, an
  arrow, a polygon), of a contour line or of a filled band (``fill_between``) lies under a
  legend's box (where the data are drawn: clipped artists count only inside their axes). Lines
  drawn across the axes in axes coordinates (``axhline``, ``axvline``) are guides, not data; a
  colour map that fills the axes (``pcolormesh``, ``imshow``) is the ground a legend stands on;
* no text placed at a data point inside its axes (``ax.text``, an annotation of a point in data
  coordinates) crosses the axes' frame: a label half outside its panel runs into the tick
  labels, a colorbar or the neighbouring panel;
* every axes that shows tick labels on an axis names that axis (a label, or, for the x axis of
  a panel whose neighbour below shares it, that neighbour's).

It returns the list of problems (empty: the figure passes), each a sentence naming the artists,
so a test reads ``assert not check_figure(fig)`` and a failure says what to fix.
"""

from __future__ import annotations

import itertools

import matplotlib

matplotlib.use("Agg")

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PathCollection, QuadMesh
from matplotlib.legend import Legend
from matplotlib.patches import Rectangle
from matplotlib.path import Path
from matplotlib.text import Annotation
from matplotlib.transforms import Bbox

#: Slack of the box tests, pixels: boxes that only touch (anti-aliasing, rounding) do not fail.
SLACK = 1.0


def _renderer(fig):
    """The figure laid out and drawn as a saved file is, and the renderer that drew it.

    One draw runs the layout engine and places every artist. With fixed-aspect axes the
    positions of axis labels read back only settle on the next draw (a saved file is drawn
    once, after the layout, as that second draw), so such a figure is drawn twice, or once
    if it was drawn before and is unchanged since (a test's own draw). Nothing is rasterised:
    the positions and extents of the artists are all the checks read.
    """
    drawn_before = isinstance(fig.canvas, FigureCanvasAgg) and not fig.stale
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fixed_aspect = any(ax.get_aspect() != "auto" for ax in fig.axes)
    draws = 2 if fixed_aspect and not drawn_before else 1
    with renderer._draw_disabled():
        for _ in range(draws):
            fig.draw(renderer)
    return renderer


def _drawn_ticklabels(axis) -> list:
    """The tick labels matplotlib draws: non-empty, visible, at ticks inside the view limits."""
    low, high = sorted(axis.get_view_interval())
    span = high - low
    labels = []
    for minor in (False, True):
        locs = axis.get_minorticklocs() if minor else axis.get_majorticklocs()
        ticks = axis.get_minor_ticks(len(locs)) if minor else axis.get_major_ticks(len(locs))
        for loc, tick in zip(locs, ticks, strict=False):
            if not low - 1e-9 * span <= loc <= high + 1e-9 * span:
                continue
            for label in (tick.label1, tick.label2):
                if label.get_visible() and label.get_text().strip():
                    labels.append(label)
    return labels


def _text_boxes(fig, renderer) -> list[tuple[str, Bbox]]:
    """``(name, display box)`` of every text the figure draws, each legend as one box."""
    items = []

    def add(name, artist):
        if artist is None or not artist.get_visible():
            return
        if not isinstance(artist, Legend) and not artist.get_text().strip():
            return
        items.append((name, artist.get_window_extent(renderer)))

    for i, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        where = f"axes {i}"
        for axis, letter in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            if not axis.get_visible():
                continue
            for label in _drawn_ticklabels(axis):
                add(f"{where} {letter} tick label {label.get_text()!r}", label)
            add(f"{where} {letter} label {axis.label.get_text()!r}", axis.label)
            add(f"{where} {letter} offset text {axis.offsetText.get_text()!r}", axis.offsetText)
        for title in (ax.title, ax._left_title, ax._right_title):
            add(f"{where} title {title.get_text()!r}", title)
        for text in ax.texts:
            add(f"{where} text {text.get_text()!r}", text)
        add(f"{where} legend", ax.get_legend())
    sup = [t for t in (fig._suptitle, fig._supxlabel, fig._supylabel) if t is not None]
    for text in fig.texts:
        if not any(text is t for t in sup):
            add(f"figure text {text.get_text()!r}", text)
    for text in sup:
        add(f"figure title {text.get_text()!r}", text)
    for j, legend in enumerate(fig.legends):
        add(f"figure legend {j}", legend)
    return items


def _shrunk(box: Bbox, by: float = SLACK) -> Bbox:
    return Bbox.from_extents(box.x0 + by, box.y0 + by, box.x1 - by, box.y1 - by)


def _segments_hit(points: np.ndarray, box: Bbox, closed: bool = False) -> bool:
    """Whether a polyline through ``points`` (display, shape (n, 2)) enters ``box``."""
    if closed and len(points) > 1:
        points = np.vstack([points, points[:1]])
    finite = np.isfinite(points).all(axis=1)
    if len(points) == 1:
        return bool(finite[0] and box.contains(*points[0]))
    a, b = points[:-1], points[1:]
    ok = finite[:-1] & finite[1:]
    a, b = a[ok], b[ok]
    if not len(a):
        return False
    # Liang-Barsky clipping of every segment at once
    d = b - a
    p = np.stack([-d[:, 0], d[:, 0], -d[:, 1], d[:, 1]], axis=1)
    q = np.stack([a[:, 0] - box.x0, box.x1 - a[:, 0], a[:, 1] - box.y0, box.y1 - a[:, 1]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = q / p
    t0 = np.max(np.where(p < 0, r, 0.0), axis=1)
    t1 = np.min(np.where(p > 0, r, 1.0), axis=1)
    parallel_out = ((p == 0) & (q < 0)).any(axis=1)
    return bool(((t0 <= t1) & ~parallel_out).any())


def _paths_hit(paths, transform, box: Bbox, filled: bool) -> bool:
    """Whether any of ``paths`` (drawn through ``transform``) has an outline in ``box`` or, if
    ``filled``, an area over the box's centre."""
    centre = ((box.x0 + box.x1) / 2.0, (box.y0 + box.y1) / 2.0)
    for path in paths:
        for polygon in path.to_polygons(transform, closed_only=False):
            if len(polygon) and _segments_hit(np.asarray(polygon, float), box):
                return True
            if filled and len(polygon) > 2 and Path(polygon).contains_point(centre):
                return True
    return False


def _filled(artist) -> bool:
    faces = np.atleast_2d(artist.get_facecolor())
    return bool(faces.size and (faces[:, 3] > 0).any()) if faces.ndim == 2 else False


def _points_hit(points: np.ndarray, box: Bbox, radius: float) -> bool:
    points = points[np.isfinite(points).all(axis=1)]
    if not len(points):
        return False
    x, y = points[:, 0], points[:, 1]
    return bool(
        (
            (x >= box.x0 - radius)
            & (x <= box.x1 + radius)
            & (y >= box.y0 - radius)
            & (y <= box.y1 + radius)
        ).any()
    )


def _is_data(artist, ax) -> bool:
    """Drawn in the axes' data coordinates in both directions (not a guide across the axes)."""
    transform = artist.get_transform()
    return transform.contains_branch(ax.transData) or (
        transform.contains_branch_seperately(ax.transData) == (True, True)
    )


def _data_under(ax, box: Bbox, renderer) -> list[str]:
    """Names of the data artists of ``ax`` drawn inside ``box`` (display)."""
    found = []
    clip_box = ax.bbox
    inside = Bbox.intersection(box, clip_box)
    dpi_scale = ax.figure.dpi / 72.0
    for k, line in enumerate(ax.lines):
        if not line.get_visible() or not _is_data(line, ax):
            continue
        where = inside if line.get_clip_on() else box
        if where is None:
            continue
        xy = line.get_transform().transform(np.column_stack(line.get_data(orig=False)))
        xy = np.asarray(xy, float)
        hit = False
        if line.get_linestyle() not in ("None", "none", "", " ") and line.get_linewidth() > 0:
            hit = _segments_hit(xy, where)
        if not hit and line.get_marker() not in (None, "None", "none", "", " "):
            hit = _points_hit(xy, where, 0.5 * line.get_markersize() * dpi_scale)
        if hit:
            found.append(f"line {k} {line.get_label()!r}")
    for k, collection in enumerate(ax.collections):
        if not collection.get_visible():
            continue
        where = inside if collection.get_clip_on() else box
        if where is None:
            continue
        if isinstance(collection, PathCollection):
            offsets = collection.get_offsets()
            if not len(offsets):
                continue
            xy = collection.get_offset_transform().transform(np.asarray(offsets, float))
            sizes = collection.get_sizes()
            radius = 0.5 * np.sqrt(float(np.max(sizes))) * dpi_scale if len(sizes) else 0.0
            if _points_hit(xy, where, radius):
                found.append(f"scatter {k} {collection.get_label()!r}")
        elif isinstance(collection, LineCollection):
            transform = collection.get_transform()
            for segment in collection.get_segments():
                if len(segment) and _segments_hit(transform.transform(segment), where):
                    found.append(f"line collection {k} {collection.get_label()!r}")
                    break
        elif not isinstance(collection, QuadMesh) and _is_data(collection, ax):
            # contour lines and filled bands (fill_between, contourf): their outlines and areas
            paths = collection.get_paths()
            if _paths_hit(paths, collection.get_transform(), where, _filled(collection)):
                found.append(f"{type(collection).__name__} {k} {collection.get_label()!r}")
    for k, patch in enumerate(ax.patches):
        if not patch.get_visible() or not _is_data(patch, ax):
            continue
        where = inside if patch.get_clip_on() else box
        if where is None:
            continue
        if isinstance(patch, Rectangle):
            if patch.get_window_extent(renderer).overlaps(where):
                found.append(f"bar {k}")
        elif _paths_hit([patch.get_path()], patch.get_transform(), where, patch.get_fill()):
            found.append(f"{type(patch).__name__} {k} {patch.get_label()!r}")
    return found


def _texts_across_frames(fig, renderer) -> list[str]:
    """Texts placed at a data point inside their axes whose box crosses the axes' frame."""
    problems = []
    for i, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        frame = ax.get_window_extent(renderer)
        for text in ax.texts:
            if not text.get_visible() or not text.get_text().strip():
                continue
            if isinstance(text, Annotation):
                if text.xycoords != "data":
                    continue  # placed in axes or figure coordinates
                anchor = ax.transData.transform(text.xy)
            else:
                if not _is_data(text, ax):
                    continue
                anchor = ax.transData.transform(text.get_position())
            if not frame.contains(*anchor):
                continue  # a text outside the axes by design
            box = _shrunk(text.get_window_extent(renderer))
            if not (
                frame.x0 <= box.x0
                and box.x1 <= frame.x1
                and frame.y0 <= box.y0
                and box.y1 <= frame.y1
            ):
                problems.append(f"axes {i} text {text.get_text()!r} crosses the axes' frame")
    return problems


def _labels_missing(fig) -> list[str]:
    problems = []
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    for ax in axes:
        for axis, letter in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            if not axis.get_visible() or not _drawn_ticklabels(axis):
                continue
            if axis.label.get_text().strip():
                continue
            if letter == "x" and _shared_label_below(ax, axes):
                continue
            if letter == "y" and _shared_label_left(ax, axes):
                continue
            if fig._supxlabel if letter == "x" else fig._supylabel:
                continue
            problems.append(
                f"axes {fig.axes.index(ax)}: {letter} tick labels but no {letter} label"
            )
    return problems


def _shared_label_below(ax, axes) -> bool:
    shared = ax.get_shared_x_axes().get_siblings(ax)
    return any(other is not ax and other.xaxis.label.get_text().strip() for other in shared) or any(
        other is not ax
        and other.get_position().y0 < ax.get_position().y0
        and other.xaxis.label.get_text().strip()
        and abs(other.get_position().x0 - ax.get_position().x0) < 1e-6
        for other in shared
    )


def _shared_label_left(ax, axes) -> bool:
    shared = ax.get_shared_y_axes().get_siblings(ax)
    return any(other is not ax and other.yaxis.label.get_text().strip() for other in shared)


def check_figure(fig, *, labels: bool = True) -> list[str]:
    """Every problem of ``fig`` the module docstring lists (empty: it passes)."""
    renderer = _renderer(fig)
    problems = []
    boxes = _text_boxes(fig, renderer)
    page = fig.bbox
    for name, box in boxes:
        if (
            box.x0 < page.x0 - SLACK
            or box.y0 < page.y0 - SLACK
            or box.x1 > page.x1 + SLACK
            or box.y1 > page.y1 + SLACK
        ):
            problems.append(f"{name} outside the figure ({box.extents.round(1)} of {page.extents})")
    for (name_a, a), (name_b, b) in itertools.combinations(boxes, 2):
        if _shrunk(a).overlaps(_shrunk(b)):
            problems.append(f"{name_a} overlaps {name_b}")
    legends = [(f"legend of axes {i}", ax.get_legend()) for i, ax in enumerate(fig.axes)]
    legends += [(f"figure legend {j}", legend) for j, legend in enumerate(fig.legends)]
    for name, legend in legends:
        if legend is None or not legend.get_visible():
            continue
        box = _shrunk(legend.get_window_extent(renderer))
        for i, ax in enumerate(fig.axes):
            if ax.get_visible():
                problems += [
                    f"{name} covers axes {i} {hit}" for hit in _data_under(ax, box, renderer)
                ]
    problems += _texts_across_frames(fig, renderer)
    if labels:
        problems += _labels_missing(fig)
    return problems


def assert_readable(fig, *, labels: bool = True) -> None:
    """Fail with every problem :func:`check_figure` finds in ``fig``."""
    problems = check_figure(fig, labels=labels)
    assert not problems, "\n".join(problems)


class captured_figures:
    """Record every Matplotlib figure saved inside the ``with`` block (``Figure.savefig``).

    A command draws and saves its figures itself; this hands them to :func:`check_figure`
    as drawn, whatever writes them (``save_figure``, a result directory's writer).
    """

    def __enter__(self) -> list:
        from matplotlib.figure import Figure

        self._original = Figure.savefig
        figures: list = []
        original = self._original

        def savefig(figure, *args, **kwargs):
            figures.append(figure)
            return original(figure, *args, **kwargs)

        Figure.savefig = savefig
        return figures

    def __exit__(self, *exc) -> None:
        from matplotlib.figure import Figure

        Figure.savefig = self._original
