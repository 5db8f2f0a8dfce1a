"""Figures a person reads at a glance: readable defaults for the report's plots, and a checker
that measures a drawn figure as the page shows it.

A report's page (``report.py``) is read in a window ``WINDOW_PX`` (1280) CSS px wide; its
content is ``CONTENT_PX`` wide and every image is scaled down to fit it (CSS ``max-width:
100%``), never up.  A figure W inches wide saved at D dots per inch is W*D px; the page shows it
at the scale s = min(1, CONTENT_PX / (W*D)), so text of p points is p * D / 72 * s CSS px there
(a 16-inch figure at 100 dpi is 1600 px, shown at 0.725: its 8-point text is 8 px).

``check(fig)`` draws the figure with matplotlib's Agg renderer, takes every text it draws
and each one's ``get_window_extent(renderer)``, and finds

* text smaller than ``min_px`` CSS px on the page (``"small"``),
* texts that overlap one another: tick labels, legend entries, titles, axis labels
  (``"overlap"``; a rotated text counts by its upright bounding box),
* text cut off by the figure's edge (``"clipped"``).

``readable(fig)`` makes a figure pass: every text at least the page's body size
(``BODY_PX``), and tick locators thinned until their labels no longer touch.  ``figure``,
``legend_outside``, ``cycles_axis``, ``thousands_axis``, ``percent_axis`` and ``index_axis``
are the defaults the plots are drawn with: a figure as wide as the page's content (so it is
shown at its natural size), legends beside the data rather than on it, and tick locators and
formatters that do not crowd (``MaxNLocator``, ``LogLocator``; ``EngFormatter`` for cycles,
thousands separators, percentages).
"""
from __future__ import annotations

from dataclasses import dataclass

WINDOW_PX = 1280      # the window a report is read in (CSS px)
CONTENT_PX = 1160     # the width of a report page's content at that window: report.py's CSS sets it
BODY_PX = 14          # the page's body text (CSS px)
MIN_PX = 12           # the smallest figure text check() lets pass
DPI = 100             # the report's figures are saved at this


@dataclass(frozen=True)
class Problem:
    """One thing check() found: kind is "small", "overlap" or "clipped"; text the string drawn;
    detail says where and by how much."""

    kind: str
    text: str
    detail: str

    def __str__(self) -> str:
        return f"{self.kind}: {self.text!r} {self.detail}"


# -- sizes on the page ---------------------------------------------------------------------------

def page_scale(fig, dpi=None, page_px: float = CONTENT_PX) -> float:
    """How much the page shrinks the figure saved at dpi (default the figure's): 1 when it fits."""
    natural = fig.get_figwidth() * (dpi or fig.dpi)
    return min(1.0, page_px / natural)


def text_px(points: float, fig, dpi=None, page_px: float = CONTENT_PX) -> float:
    """The CSS px on the page of text of the given points in the figure saved at dpi."""
    dpi = dpi or fig.dpi
    return points * dpi / 72 * page_scale(fig, dpi, page_px)


def points_for(px: float, fig, dpi=None, page_px: float = CONTENT_PX) -> float:
    """The points a text needs in the figure saved at dpi to be px CSS px on the page."""
    dpi = dpi or fig.dpi
    return px * 72 / (dpi * page_scale(fig, dpi, page_px))


def body_points(fig, dpi=None, page_px: float = CONTENT_PX) -> float:
    """The points of the page's body text size in this figure."""
    return points_for(BODY_PX, fig, dpi, page_px)


# -- the checker ----------------------------------------------------------------------------------

def _agg_canvas(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    return fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)


def drawn_texts(fig, dpi=None) -> list:
    """(Text, window extent in pixels at dpi) of every non-blank text the Agg renderer draws for
    the figure (a tick outside the view, an invisible artist or an empty string draws none)."""
    canvas = _agg_canvas(fig)
    old = fig.dpi
    if dpi and dpi != old:
        fig.set_dpi(dpi)
    try:
        renderer = canvas.get_renderer()
        renderer.clear()
        seen: dict = {}
        real = renderer.draw_text

        def record(gc, x, y, s, prop, angle, ismath=False, mtext=None):
            if mtext is not None and s.strip():
                seen.setdefault(id(mtext), mtext)
            return real(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)

        renderer.draw_text = record          # this renderer only, for this one drawing
        try:
            fig.draw(renderer)
        finally:
            del renderer.draw_text
        return [(t, t.get_window_extent(renderer)) for t in seen.values()]
    finally:
        if fig.dpi != old:
            fig.set_dpi(old)


def _where(t, owner: dict) -> str:
    ax = owner.get(id(t))
    if ax is None:
        return "in the figure"
    title = ax.get_title() or ax.get_ylabel() or ax.get_xlabel()
    return f"in the axes {title!r}" if title else "in an untitled axes"


def check(fig, dpi=None, page_px: float = CONTENT_PX, min_px: float = MIN_PX) -> list:
    """The Problems of the figure saved at dpi (default its own) on a page page_px wide: text
    under min_px CSS px, texts overlapping (by more than a pixel each way), text past the figure's
    edge.  An empty list when a person can read it at a glance."""
    from matplotlib.text import Text

    dpi = dpi or fig.dpi
    scale = page_scale(fig, dpi, page_px)
    texts = drawn_texts(fig, dpi)
    owner = {id(t): ax for ax in fig.axes for t in ax.findobj(Text)}      # the axes each text belongs to
    width, height = fig.get_figwidth() * dpi, fig.get_figheight() * dpi
    out = []
    for t, box in texts:
        where, px = _where(t, owner), t.get_fontsize() * dpi / 72 * scale
        if px < min_px - 0.01:
            out.append(Problem("small", t.get_text(),
                               f"{where} is {px:.1f} px on a page {page_px:g} px wide (at least {min_px:g})"))
        if box.x0 < -1 or box.y0 < -1 or box.x1 > width + 1 or box.y1 > height + 1:
            out.append(Problem("clipped", t.get_text(),
                               f"{where} runs past the figure's edge ({box.x0:.0f}..{box.x1:.0f} x "
                               f"{box.y0:.0f}..{box.y1:.0f} in {width:.0f} x {height:.0f} px)"))
    for i, (a, abox) in enumerate(texts):
        for b, bbox in texts[i + 1:]:
            w = min(abox.x1, bbox.x1) - max(abox.x0, bbox.x0)
            h = min(abox.y1, bbox.y1) - max(abox.y0, bbox.y0)
            if w > 1 and h > 1:
                out.append(Problem("overlap", a.get_text(), f"{_where(a, owner)} overlaps {b.get_text()!r} "
                                                            f"{_where(b, owner)} by {w:.0f} x {h:.0f} px"))
    return out


# -- readable defaults --------------------------------------------------------------------------------

def figure(height_in: float, nrows: int = 1, ncols: int = 1, dpi: int = DPI, width_px: float = CONTENT_PX,
           **subplots):
    """(Figure, 2-D array of axes): as wide as the page's content at dpi (shown at its natural size),
    with matplotlib's constrained layout (room made for labels and legends beside the axes) and an
    Agg canvas; no pyplot state, so nothing to close."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_px / dpi, height_in), dpi=dpi, layout="constrained")
    _agg_canvas(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False, **subplots)


def legend_outside(ax, fig=None, **kw):
    """A legend beside the axes' right edge (off the data) in body-size text; on a figure (ax is
    the Figure) beside all its axes at the upper right (constrained layout makes room for it)."""
    from matplotlib.figure import Figure

    if isinstance(ax, Figure):
        kw = {"loc": "outside right upper", "frameon": False, "fontsize": body_points(ax), **kw}
        return ax.legend(**kw)
    kw = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0, "frameon": False,
          "fontsize": body_points(fig or ax.figure), **kw}
    return ax.legend(**kw)


def cycles_axis(axis, log: bool = False) -> None:
    """Cycles (or any large count) with engineering prefixes: 500 k, 1.5 M; on a log scale the
    major ticks at 1, 2 and 5 of each decade, the minor ones unlabelled."""
    from matplotlib import ticker

    if log:
        axis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_minor_locator(ticker.LogLocator(subs="auto"))
        axis.set_minor_formatter(ticker.NullFormatter())
    else:
        axis.set_major_locator(ticker.MaxNLocator(nbins="auto", steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(ticker.EngFormatter(sep=" "))


def thousands_axis(axis, integer: bool = True) -> None:
    """Plain numbers with thousands separators: 1,000 2,000."""
    from matplotlib import ticker

    axis.set_major_locator(ticker.MaxNLocator(nbins="auto", integer=integer, steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(ticker.StrMethodFormatter("{x:,.0f}" if integer else "{x:,g}"))


def percent_axis(axis, top: float = 1.0) -> None:
    """A fraction shown as a percentage (0.5 -> 50%)."""
    from matplotlib import ticker

    axis.set_major_locator(ticker.MaxNLocator(nbins="auto", steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(ticker.PercentFormatter(xmax=top, decimals=0))


def index_axis(axis, labels) -> None:
    """Categories at 0, 1, ... n-1 named by labels, thinned like numbers when they crowd."""
    from matplotlib import ticker

    labels = [str(x) for x in labels]
    axis.set_major_locator(ticker.MaxNLocator(nbins="auto", integer=True, min_n_ticks=1))
    axis.set_major_formatter(ticker.FuncFormatter(
        lambda x, _pos: labels[int(round(x))] if abs(x - round(x)) < 1e-9 and 0 <= round(x) < len(labels) else ""))


def _tick_axes(fig):
    for ax in fig.axes:
        yield from (ax.xaxis, ax.yaxis)


def _room(axis, drawn):
    """None if the axis's drawn major tick labels are apart (by half their height), else how
    many such labels its length has room for, side by side with half a label between them."""
    from matplotlib.axis import XAxis

    labels = {id(x) for t in axis.get_major_ticks() for x in (t.label1, t.label2)}
    boxes = [box for t, box in drawn if id(t) in labels]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            pad = 0.5 * min(a.height, b.height)
            if a.x1 + pad > b.x0 and b.x1 + pad > a.x0 and a.y1 + pad > b.y0 and b.y1 + pad > a.y0:
                along = XAxis if isinstance(axis, XAxis) else None
                size = max(x.width if along else x.height for x in boxes)
                length = axis.axes.bbox.width if along else axis.axes.bbox.height
                return max(1, int(length / (1.5 * size)))
    return None


def readable(fig, dpi=None, body_px: float = BODY_PX, page_px: float = CONTENT_PX, rounds: int = 8):
    """Raise every text of the figure to at least body_px CSS px on the page (tick labels too,
    those not yet made included), then thin the major ticks of each axis whose labels touch, to
    as many as its length has room for (a MaxNLocator's bins; a LogLocator first one tick a
    decade, then fewer), until none touch.  Returns the figure."""
    from matplotlib import ticker
    from matplotlib.text import Text

    pt = points_for(body_px, fig, dpi, page_px)
    for ax in fig.axes:
        ax.tick_params(which="both", labelsize=pt)
    for t in fig.findobj(Text):
        if t.get_fontsize() < pt:
            t.set_fontsize(pt)
    decades_only = set()       # log axes already down to one tick a decade
    for _ in range(rounds):
        drawn = drawn_texts(fig, dpi)
        thinned = False
        for axis in _tick_axes(fig):
            room = _room(axis, drawn)
            if room is None:
                continue
            loc = axis.get_major_locator()
            n = len(axis.get_majorticklocs())
            if isinstance(loc, ticker.MaxNLocator) and n > 2:
                loc.set_params(nbins=max(1, min(room - 1, n - 2)))
                thinned = True
            elif isinstance(loc, ticker.LogLocator) and id(axis) not in decades_only:
                loc.set_params(subs=(1.0,))
                decades_only.add(id(axis))
                thinned = True
            elif isinstance(loc, ticker.LogLocator) and n > 2:
                loc.set_params(numticks=max(2, min(room, n - 1)))
                thinned = True
        if not thinned:
            break
    return fig
