"""A small raster chart drawn with Pillow: axes holding images, lines, shaded spans and error bars,
with ticks, labels, titles, a legend and colour bars, written as a PNG.

Why not matplotlib: importing it takes 0.3-0.4 s and drawing the alignment plot's ten axes
another 0.4 s, against issue 12's 0.5 s for the whole plot. Pillow (which matplotlib itself
writes PNGs with, so it is installed wherever matplotlib is) imports in about 15 ms, and this
module draws the same figure in well under 0.1 s.

A figure is a scene first: :class:`Axes` keep what was added to them (``images``, ``lines``,
``spans``, ``errorbars``, titles, labels, legend) so tests can read it, and
:meth:`Figure.save` draws it all at ``SUPERSAMPLE`` times the resolution and halves it, which
smooths the edges of lines and text (:mod:`splicer._paint`). Sizes follow matplotlib's
conventions: inches and dots per inch for the figure, points (1/72 in) for line widths, marker
sizes and fonts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Axes", "Figure", "nice_ticks", "tick_labels", "viridis", "widened"]

SUPERSAMPLE = 2

# viridis (matplotlib's default colour map, CC0) at 17 evenly spaced points, 8-bit RGB; interpolated linearly
_VIRIDIS = np.array([
    [68, 1, 84], [72, 24, 106], [71, 45, 123], [66, 64, 134], [59, 82, 139], [51, 99, 141], [44, 114, 142],
    [38, 130, 142], [33, 145, 140], [31, 160, 136], [40, 174, 128], [63, 188, 115], [94, 201, 98],
    [132, 212, 75], [173, 220, 48], [216, 226, 25], [253, 231, 37]], dtype=float)

Color = tuple  # (r, g, b) in 0..255


def _lut() -> np.ndarray:
    """257 colours: viridis at 256 levels, then white (for NaN)."""
    t = np.linspace(0.0, len(_VIRIDIS) - 1, 256)
    k = np.minimum(t.astype(int), len(_VIRIDIS) - 2)
    f = (t - k)[:, None]
    rgb = _VIRIDIS[k] * (1.0 - f) + _VIRIDIS[k + 1] * f
    return np.rint(np.vstack([rgb, [255.0, 255.0, 255.0]])).astype(np.uint8)


_LUT = _lut()


def viridis(values: np.ndarray, vmin: float, vmax: float) -> np.ndarray:
    """RGB colours of ``values`` on viridis (256 levels) from ``vmin`` to ``vmax``; NaN comes out white.

    Parameters
    ----------
    values : np.ndarray [shape=(...)]
    vmin, vmax : float
        Values mapped to the map's ends (clipped beyond them).

    Returns
    -------
    np.ndarray [shape=(..., 3), dtype=uint8]

    Examples
    --------
    >>> viridis(np.array([0.0, 1.0, np.nan]), 0.0, 1.0).tolist()
    [[68, 1, 84], [253, 231, 37], [255, 255, 255]]
    """
    v = np.asarray(values, dtype=float)
    span = vmax - vmin if vmax > vmin else 1.0
    with np.errstate(invalid="ignore"):
        idx = np.clip((v - vmin) * (255.0 / span) + 0.5, 0, 255).astype(np.intp)
    idx[np.isnan(v)] = 256
    return _LUT[idx]


def widened(lo: float, hi: float) -> tuple[float, float]:
    """``(lo, hi)``, or one unit around ``lo`` when the range has no width (a one-frame take):
    matplotlib's rule for a singular view, used here for views and image extents alike.

    >>> widened(0.0, 2.0), widened(3.0, 3.0)
    ((0.0, 2.0), (2.5, 3.5))
    """
    lo, hi = float(lo), float(hi)
    return (lo, hi) if hi > lo else (lo - 0.5, lo + 0.5)


def nice_ticks(lo: float, hi: float, nbins: int = 5, *, integer: bool = False) -> np.ndarray:
    """At most ``nbins + 1`` evenly spaced round values inside ``[lo, hi]``.

    The step is 1, 2, 2.5 or 5 times a power of ten, the smallest that keeps within ``nbins + 1``
    ticks (``integer``: whole steps only, so no 2.5 below 10).

    Examples
    --------
    >>> nice_ticks(0, 600).tolist()
    [0.0, 200.0, 400.0, 600.0]
    >>> nice_ticks(0.05, 1.83).tolist()
    [0.5, 1.0, 1.5]
    >>> nice_ticks(0, 3, integer=True).tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo]) if math.isfinite(lo) else np.array([])
    raw = (hi - lo) / nbins
    mag = 10.0 ** math.floor(math.log10(raw))
    for s in (1.0, 2.0, 2.5, 5.0, 10.0, 20.0):
        step = s * mag
        if integer and (step < 1 or abs(step - round(step)) > 1e-9):
            continue
        first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
        if last - first + 1 <= nbins + 1:
            return np.arange(first, last + 1) * step
    return np.array([lo, hi])


def tick_labels(ticks: np.ndarray) -> list[str]:
    """Labels with as many decimals as the step needs (``[0.4, 0.8]`` -> ``0.4, 0.8``; ``[0, 200]`` -> ``0, 200``).

    >>> tick_labels(np.array([0.0, 0.25, 0.5]))
    ['0.00', '0.25', '0.50']
    """
    if len(ticks) == 0:
        return []
    step = float(np.min(np.diff(ticks))) if len(ticks) > 1 else max(abs(float(ticks[0])), 1.0)
    decimals = 0
    while decimals < 6 and abs(step * 10 ** decimals - round(step * 10 ** decimals)) > 1e-6 * max(step * 10 ** decimals, 1):
        decimals += 1
    return [f"{0.0 if abs(t) < 1e-12 else t:.{decimals}f}" for t in ticks]


@dataclass(frozen=True)
class Image:
    """An array drawn over ``extent`` (data units: left, right, bottom, top); ``data[row, col]``
    with row 0 at the bottom; each pixel takes its nearest sample."""

    data: np.ndarray
    extent: tuple
    vmin: float
    vmax: float


@dataclass(frozen=True)
class Line:
    x: np.ndarray
    y: np.ndarray
    color: Color
    lw: float  # points
    alpha: float = 1.0
    dashed: bool = False
    label: str | None = None


@dataclass(frozen=True)
class Spans:
    """Vertical bands over the axes' height, one per ``(x0, x1)`` in data units; one legend entry."""

    ranges: tuple
    color: Color
    alpha: float
    label: str | None = None


@dataclass(frozen=True)
class ErrorBars:
    x: np.ndarray
    y: np.ndarray
    yerr: np.ndarray
    color: Color
    ms: float  # marker diameter, points
    capsize: float  # points
    lw: float  # points


@dataclass
class Axes:
    """One set of axes at ``rect`` = ``[left, bottom, width, height]`` in figure fractions."""

    rect: tuple
    images: list = field(default_factory=list)
    lines: list = field(default_factory=list)
    spans: list = field(default_factory=list)
    errorbars: list = field(default_factory=list)
    title: str = ""
    title_size: float = 10.0
    title_loc: str = "center"
    xlabel: str = ""
    ylabel: str = ""
    label_size: float = 10.0
    tick_size: float = 10.0
    xlim: tuple | None = None
    ylim: tuple | None = None
    legend_size: float | None = None  # a legend in the upper left when set
    nbins: int = 5
    integer: bool = True
    ticks_right: bool = False  # a colour bar: y ticks and label on the right, no x ticks
    show_x: bool = True

    def imshow(self, data: np.ndarray, extent: tuple) -> Image:
        finite = np.asarray(data, dtype=float)[np.isfinite(data)]
        lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        im = Image(np.asarray(data, dtype=float), tuple(float(e) for e in extent), lo, hi if hi > lo else lo + 1.0)
        self.images.append(im)
        return im

    def plot(self, x, y, color: Color, lw: float, *, alpha: float = 1.0, dashed: bool = False, label: str | None = None):
        self.lines.append(Line(np.asarray(x, dtype=float), np.asarray(y, dtype=float), color, lw, alpha, dashed, label))

    def axvspans(self, ranges, color: Color, alpha: float, label: str | None = None):
        self.spans.append(Spans(tuple((float(a), float(b)) for a, b in ranges), color, alpha, label))

    def errorbar(self, x, y, yerr, color: Color, *, ms: float = 4.0, capsize: float = 3.0, lw: float = 1.5):
        if len(x):
            self.errorbars.append(ErrorBars(np.asarray(x, dtype=float), np.asarray(y, dtype=float),
                                            np.asarray(yerr, dtype=float), color, ms, capsize, lw))

    def limits(self) -> tuple[tuple, tuple]:
        """``(xlim, ylim)``: as set, else the lines' and error bars' extent with 5 % margins (matplotlib's)."""
        xs = [ln.x for ln in self.lines] + [e.x for e in self.errorbars]
        ys = [ln.y for ln in self.lines] + [e.y - e.yerr for e in self.errorbars] + [e.y + e.yerr for e in self.errorbars]

        def auto(arrays):
            vals = np.concatenate([a[np.isfinite(a)] for a in arrays]) if arrays else np.array([])
            if not vals.size:
                return (0.0, 1.0)
            lo, hi = float(vals.min()), float(vals.max())
            pad = 0.05 * (hi - lo) if hi > lo else 0.5
            return (lo - pad, hi + pad)

        return widened(*(self.xlim or auto(xs))), widened(*(self.ylim or auto(ys)))

    def xticks(self) -> np.ndarray:
        lo, hi = self.limits()[0]
        return nice_ticks(lo, hi, self.nbins, integer=self.integer) if self.show_x else np.array([])

    def yticks(self) -> np.ndarray:
        lo, hi = self.limits()[1]
        return nice_ticks(lo, hi, self.nbins, integer=self.integer)


class Figure:
    """A figure of ``width`` x ``height`` inches at ``dpi``: :meth:`add_axes`, then :meth:`save`."""

    def __init__(self, width: float, height: float, dpi: float):
        self.width, self.height, self.dpi = float(width), float(height), float(dpi)
        self.axes: list[Axes] = []

    @property
    def size_px(self) -> tuple[int, int]:
        """The PNG's (width, height) in pixels."""
        return round(self.width * self.dpi), round(self.height * self.dpi)

    def add_axes(self, rect, **kw) -> Axes:
        ax = Axes(tuple(rect), **kw)
        self.axes.append(ax)
        return ax

    def colorbar(self, im: Image, cax: Axes, label: str, *, label_size: float = 8.0) -> None:
        """``cax`` becomes a vertical colour bar of ``im``'s colours, ticks and ``label`` on its right."""
        cax.images.append(Image(np.linspace(im.vmin, im.vmax, 256)[:, None], (0.0, 1.0, im.vmin, im.vmax), im.vmin, im.vmax))
        cax.xlim, cax.ylim = (0.0, 1.0), (im.vmin, im.vmax)
        cax.ylabel, cax.label_size, cax.ticks_right, cax.show_x, cax.integer = label, label_size, True, False, False

    def render(self):
        """The figure as a Pillow RGB image of :attr:`size_px`."""
        from PIL import Image as PILImage

        from ._paint import Painter

        s = SUPERSAMPLE
        w, h = self.size_px
        canvas = PILImage.new("RGB", (w * s, h * s), "white")
        painter = Painter(canvas, self.dpi * s / 72.0)
        for ax in self.axes:
            painter.axes(ax)
        return canvas.reduce(s) if s > 1 else canvas

    def save(self, file) -> None:
        """Write the PNG to ``file`` (a path or a binary file object)."""
        self.render().save(file, format="PNG", compress_level=3)
