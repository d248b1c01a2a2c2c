"""The explorer's page as a Bokeh document: views that forward gestures to an ExploreSession.

The page is a row of views, each built by one function of :data:`VIEWS` from the session and the
:class:`Page` (which holds the models views share): the filters, the map, the designs found for
a target. A scene's view (the gripper's apertures, the sorting classes) is one more function in
that table, drawing from the same session and the same picks.

Every callback is a method of :class:`Page` that calls the session and redraws
(:meth:`Page.on_filters`, :meth:`Page.on_ranges`, :meth:`Page.on_tap`, :meth:`Page.on_target`),
so tests call them directly on a document built in Python.
"""

from __future__ import annotations

import base64
import html
import logging
from collections.abc import Callable

import numpy as np
from bokeh.events import RangesUpdate, Tap
from bokeh.layouts import column, row
from bokeh.models import (
    Button,
    CheckboxGroup,
    ColumnDataSource,
    Div,
    LayoutDOM,
    Range1d,
    RangeSlider,
    Select,
    TextInput,
)
from bokeh.plotting import figure

from ..lookup.results import VERIFIED_NOTE
from .data import Filters
from .raster import category_colours
from .session import ExploreSession, TapResult

__all__ = ["VIEWS", "Page", "build_document"]

logger = logging.getLogger(__name__)

#: Colours of the fingers' states in the detail view (matched state first).
_STATE_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")


class Page:
    """The models of one page and its callbacks (see the module docstring)."""

    def __init__(self, session: ExploreSession) -> None:
        self.session = session
        data = session.data
        self.count = Div(name="count", text="")
        self.message = Div(name="message", text="")
        self.legend = Div(name="legend", text="")
        self.colour = Select(
            name="colour",
            title="Colour by",
            value=session.colour,
            options=session.colour_options(),
        )
        self.n_units = CheckboxGroup(
            name="n_units",
            labels=[f"N = {n}" for n in data.n_values],
            active=list(range(len(data.n_values))),
        )
        self.material = Select(
            name="material",
            title="Material",
            value="any",
            options=["any", *data.materials_present],
        )
        self.constants = Div(
            name="constants",
            text=f"Constants set: <b>{html.escape(data.constants.label)}</b> (the dataset's)",
        )
        self.state = TextInput(name="state", title="State pattern (0, 1, * any)", value="")
        self.statuses = CheckboxGroup(
            name="statuses",
            labels=list(data.status_labels),
            active=list(range(len(data.status_labels))),
        )
        numeric = list(data.columns)
        self.range_column = Select(
            name="range_column",
            title="Range of",
            value=numeric[0] if numeric else "",
            options=numeric,
        )
        self.range = RangeSlider(name="range", title="", start=0, end=1, value=(0, 1), step=0.001)
        self.ranges: dict[str, tuple[float, float]] = {}
        self.target = TextInput(name="target", title="Target tip x, y (mm)", value="")
        self.find = Button(name="find", label="Find designs", button_type="primary")
        self.raster = ColumnDataSource(
            name="raster", data={"image": [], "x": [], "y": [], "dw": [], "dh": []}
        )
        self.marks = ColumnDataSource(name="marks", data={"x": [], "y": []})
        self.picks_source = ColumnDataSource(
            name="picks", data={"xs": [], "ys": [], "colour": [], "width": []}
        )
        self.pick_targets = ColumnDataSource(name="pick_targets", data={"x": [], "y": []})
        self.details = Div(name="details", text="<i>Click the map or type a target.</i>")
        self.map: figure | None = None
        self.fingers: figure | None = None

    # ------------------------------------------------------------------ callbacks

    def on_filters(self) -> None:
        """Read the filter widgets, apply them, redraw the map and the counts."""
        data = self.session.data
        ranges = dict(self.ranges)
        name = self.range_column.value
        if name:
            low, _ = data.finite_range(name)
            if self.range.value != (self.range.start, self.range.end) and np.isfinite(low):
                ranges[name] = tuple(float(v) for v in self.range.value)
            else:
                ranges.pop(name, None)
        self.ranges = ranges
        filters = Filters(
            n_units=tuple(data.n_values[i] for i in sorted(self.n_units.active)),
            material=None if self.material.value == "any" else self.material.value,
            state=self.state.value,
            statuses=tuple(data.status_labels[i] for i in sorted(self.statuses.active)),
            ranges=ranges,
        )
        try:
            self.session.set_filters(filters)
        except ValueError as exc:
            self.message.text = f"<span style='color:#b00'>{html.escape(str(exc))}</span>"
            return
        self.message.text = ""
        self.redraw()

    def on_range_column(self) -> None:
        """Show the chosen column's range on the slider (its filter kept as set)."""
        name = self.range_column.value
        low, high = self.session.data.finite_range(name)
        if not np.isfinite(low):
            low, high = 0.0, 1.0
        if high <= low:
            high = low + 1e-9
        self.range.update(
            start=low, end=high, step=(high - low) / 1000, value=self.ranges.get(name, (low, high))
        )
        self.range.title = f"{name} ({self.session.data.units.get(name, '')})"

    def on_colour(self) -> None:
        """Colour the map by the chosen column."""
        self.session.set_colour(self.colour.value)
        self.redraw()

    def on_ranges(self, event: RangesUpdate) -> None:
        """Zoom or pan: render the visible range at full resolution."""
        self.draw_raster((event.x0, event.x1), (event.y0, event.y1))

    def on_tap(self, event: Tap) -> TapResult:
        """A click on the map: the designs whose tip is nearest to it."""
        return self.show(self.session.tap(event.x, event.y))

    def on_target(self) -> TapResult | None:
        """A typed target ``x, y``."""
        try:
            x, y = (float(v) for v in self.target.value.replace(";", ",").split(","))
        except ValueError:
            self.details.text = (
                f"<span style='color:#b00'>target {html.escape(self.target.value)!r}: give two "
                "numbers x, y in mm</span>"
            )
            return None
        return self.show(self.session.tap(x, y))

    # ------------------------------------------------------------------ drawing

    def redraw(self) -> None:
        """Counts, legend and the map at the current range."""
        session = self.session
        total = len(session.data)
        self.count.text = (
            f"<b>{session.count:,}</b> of {total:,} rows shown"
            f"<span hidden data-count='{session.count}' data-total='{total}'></span>"
        )
        counts = session.counts()
        self.n_units.labels = [f"N = {n} ({c:,})" for n, c in counts["n_units"].items()]
        self.statuses.labels = [f"{s} ({c:,})" for s, c in counts["status"].items()]
        self.draw_raster(session.x_range, session.y_range)
        self.draw_legend()

    def draw_raster(self, x_range, y_range) -> None:
        """Render and send the map image."""
        raster = self.session.render(x_range, y_range)
        (x0, x1), (y0, y1) = raster.x_range, raster.y_range
        self.raster.data = {
            "image": [raster.image],
            "x": [x0],
            "y": [y0],
            "dw": [x1 - x0],
            "dh": [y1 - y0],
        }

    def draw_legend(self) -> None:
        """Swatches of a category colouring, or the colour map's limits."""
        session = self.session
        items = session.categories()
        if items:
            colours = category_colours(max(i for _, i in items) + 1) if items[0][1] >= 0 else []
            parts = [
                f"<span style='color:rgb{tuple(int(c) for c in colours[i])}'>&#9632;</span> "
                f"{html.escape(label)}"
                if i >= 0
                else html.escape(label)
                for label, i in items
            ]
            self.legend.text = " &nbsp; ".join(parts)
        else:
            low, high = session._limits(session.colour)
            unit = session.data.units.get(session.colour, "")
            self.legend.text = (
                f"{html.escape(session.colour)}: mean per pixel, viridis from {low:.4g} to "
                f"{high:.4g} {html.escape(unit)}"
            )

    def show(self, result: TapResult) -> TapResult:
        """Mark the target, draw the picks' fingers and write their numbers."""
        tx, ty = result.target
        self.marks.data = {"x": [tx], "y": [ty]}
        self.pick_targets.data = {"x": [tx], "y": [ty]}
        if result.error:
            self.details.text = f"<span style='color:#b00'>{html.escape(result.error)}</span>"
            self.picks_source.data = {"xs": [], "ys": [], "colour": [], "width": []}
            return result
        # drawn bottom to top: the other picks' matched states (grey), the best pick's other
        # states, then its matched state, thick, ending at the target
        lines = [(p.states[0], "#aaa", 2.0) for p in result.picks[1:] if p.states[0].stable]
        if result.picks:
            best = result.picks[0].states
            lines += [
                (s, _STATE_COLOURS[1 + j % (len(_STATE_COLOURS) - 1)], 1.5)
                for j, s in enumerate(best[1:])
                if s.stable
            ]
            lines += [(best[0], _STATE_COLOURS[0], 3.5)] if best[0].stable else []
        xs = [s.nodes[1::2, 0].tolist() for s, _, _ in lines]
        ys = [s.nodes[1::2, 1].tolist() for s, _, _ in lines]
        colours = [c for _, c, _ in lines]
        widths = [w for _, _, w in lines]
        blocks = [_pick_html(rank, pick) for rank, pick in enumerate(result.picks, start=1)]
        self.picks_source.data = {"xs": xs, "ys": ys, "colour": colours, "width": widths}
        if self.fingers is not None and xs:
            x = np.concatenate([np.asarray(v) for v in xs] + [[tx, 0.0]])
            y = np.concatenate([np.asarray(v) for v in ys] + [[ty, 0.0]])
            half = max(np.ptp(x), np.ptp(y) * 360 / 300) / 2 * 1.1 + 1.0
            cx, cy = (x.max() + x.min()) / 2, (y.max() + y.min()) / 2
            self.fingers.x_range.update(start=cx - half, end=cx + half)
            self.fingers.y_range.update(start=cy - half * 300 / 360, end=cy + half * 300 / 360)
        self.details.text = (
            f"<p>Target ({tx:.4g}, {ty:.4g}) mm: {len(result.picks)} design"
            f"{'s' if len(result.picks) != 1 else ''} in {result.seconds * 1e3:.0f} ms. "
            f"{html.escape(VERIFIED_NOTE)}.</p>" + "".join(blocks)
        )
        return result


def _pick_html(rank: int, pick) -> str:
    """One design's numbers, how it was verified, and its TOML as a download link."""
    c = pick.candidate
    d = c.design
    refinement = c.refinement
    how = (
        f"refined with the exact model ({refinement.evaluations} evaluations, "
        f"{refinement.jacobians} Jacobians: {html.escape(refinement.status)}), then re-solved"
        if refinement is not None
        else "re-solved by the exact model"
    )
    stable = ", ".join(s.requested for s in pick.states if s.stable)
    resets = "".join(
        f"<li>{html.escape(name)} = {value:.4g} s (dataset row)</li>"
        for name, value in pick.dataset_values.items()
        if np.isfinite(value)
    )
    outside = (
        ""
        if c.fitted_range
        else f"; outside the fitted range: {html.escape(str(c.fitted_range_note))}"
    )
    payload = base64.b64encode(pick.toml.encode()).decode()
    error = f"{c.error_mm:.3g} mm" if c.error_mm is not None else f"{c.error:.3g}"
    return (
        f"<div class='pick' data-rank='{rank}' data-design-id='{c.design_id}' "
        f"data-status='{html.escape(c.status)}' data-error-mm='{c.error_mm}'>"
        f"<h4>#{rank}: N = {d.n_units}, state {html.escape(c.state)} "
        f"<small>(row design_id {c.design_id})</small></h4><ul>"
        f"<li>status <b>{html.escape(c.status)}</b>, tip error after refinement {error}</li>"
        f"<li>tip ({c.tip[0]:.5g}, {c.tip[1]:.5g}) mm, stiffness {c.stiffness:.4g} N/mm</li>"
        f"<li>stable states drawn: {html.escape(stable)}</li>{resets}"
        f"<li>H = {', '.join(f'{h:.4g}' for h in d.H)} mm; t = {d.t:.4g}, t_lim = "
        f"{d.t_lim:.4g} mm; E = {d.E:.4g} MPa</li>"
        f"<li>verified: {how}"
        f"{outside}"
        "</li></ul>"
        f"<a class='download' download='design-{rank}-row{c.design_id}.toml' "
        f"href='data:application/toml;base64,{payload}'>Download design TOML</a></div>"
    )


def _filters_view(session: ExploreSession, page: Page) -> LayoutDOM:
    def filters(attr, old, new) -> None:
        page.on_filters()

    for widget in (page.n_units, page.statuses):
        widget.on_change("active", filters)
    page.material.on_change("value", filters)
    page.state.on_change("value", filters)
    page.range.on_change("value_throttled", filters)
    page.range_column.on_change("value", lambda attr, old, new: page.on_range_column())
    page.colour.on_change("value", lambda attr, old, new: page.on_colour())
    page.on_range_column()
    return column(
        Div(text=f"<h3>{html.escape(session.data.root.name)}</h3>"),
        page.count,
        page.colour,
        Div(text="Number of units"),
        page.n_units,
        page.material,
        page.constants,
        page.state,
        Div(text="Status"),
        page.statuses,
        page.range_column,
        page.range,
        page.message,
        width=260,
    )


def _map_view(session: ExploreSession, page: Page) -> LayoutDOM:
    (x0, x1), (y0, y1) = session.x_range, session.y_range
    fig = figure(
        name="map",
        x_range=Range1d(x0, x1),
        y_range=Range1d(y0, y1),
        frame_width=session.width,
        frame_height=session.height,
        tools="pan,wheel_zoom,box_zoom,reset,tap",
        active_scroll="wheel_zoom",
        x_axis_label="tip x (mm)",
        y_axis_label="tip y (mm)",
        title="Tips of every design-state row (click: designs for that tip)",
        output_backend="canvas",
        # a zoom or pan is sent (RangesUpdate) this long after the gesture stops: BokehJS's
        # default, 500 ms, would be most of the time to the full-resolution image
        lod_timeout=40,
    )
    fig.image_rgba(image="image", x="x", y="y", dw="dw", dh="dh", source=page.raster)
    fig.scatter("x", "y", source=page.marks, marker="x", size=16, line_width=3, color="black")
    fig.on_event(RangesUpdate, page.on_ranges)
    fig.on_event(Tap, page.on_tap)
    page.map = fig
    return column(fig, page.legend)


def _detail_view(session: ExploreSession, page: Page) -> LayoutDOM:
    fig = figure(
        name="fingers",
        x_range=Range1d(-5.0, 60.0),
        y_range=Range1d(-5.0, 50.0),
        frame_width=360,
        frame_height=300,
        title="Best design: matched state (red), sequential states; others grey",
        x_axis_label="x (mm)",
        y_axis_label="y (mm)",
        tools="pan,wheel_zoom,reset",
    )
    fig.multi_line("xs", "ys", source=page.picks_source, color="colour", line_width="width")
    fig.scatter(
        "x", "y", source=page.pick_targets, marker="x", size=14, line_width=3, color="black"
    )
    page.find.on_click(lambda event: page.on_target())
    page.fingers = fig
    return column(row(page.target, page.find), fig, page.details, width=420)


#: The page's views, left to right: (name, builder(session, page) -> layout).
VIEWS: tuple[tuple[str, Callable[[ExploreSession, Page], LayoutDOM]], ...] = (
    ("filters", _filters_view),
    ("map", _map_view),
    ("designs", _detail_view),
)


def build_document(doc, session: ExploreSession) -> Page:
    """Fill a Bokeh document with the page over ``session``; returns the page."""
    page = Page(session)
    layout = row(*(build(session, page) for _, build in VIEWS))
    page.redraw()
    doc.add_root(layout)
    doc.title = f"dpfexplore explore: {session.data.root.name}"
    return page
