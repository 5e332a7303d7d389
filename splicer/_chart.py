"""A small raster chart drawn with Pillow: axes holding images, lines, shaded spans and error bars,
with ticks, labels, titles, a legend and colour bars, written as a PNG.

Why not matplotlib: importing it takes 0.3-0.4 s and drawing the alignment plot's ten axes
another 0.4 s, against issue 12's 0.5 s for the whole plot. Pillow (which matplotlib itself
writes PNGs with, so it is installed wherever matplotlib is) imports in about 15 ms, and this
module draws the same figure in well under 0.1 s.

A figure is a scene first: :class:`Axes` keep what was added to them (``images``, ``lines``,
``spans``, ``errorbars``, titles, labels, legend) so tests can read it, and
:meth:`Figure.save` draws it all at ``SUPERSAMPLE`` times the resolution and halves it, which
smooths the edges of lines and text. Sizes follow matplotlib's conventions: inches and dots
per inch for the figure, points (1/72 in) for line widths, marker sizes and fonts.
"""

from __future__ import annotations

import importlib.util
import math
import os
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Axes", "Figure", "nice_ticks", "tick_labels", "viridis"]

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


def _font_file() -> str | None:
    """DejaVu Sans from matplotlib's data (found without importing matplotlib), else None."""
    spec = importlib.util.find_spec("matplotlib")
    for root in (spec.submodule_search_locations or []) if spec else []:
        path = os.path.join(root, "mpl-data", "fonts", "ttf", "DejaVuSans.ttf")
        if os.path.exists(path):
            return path
    return None


_FONTS: dict = {}


def _font(px: int):
    from PIL import ImageFont

    if px not in _FONTS:
        path = _font_file()
        if path is not None:
            _FONTS[px] = ImageFont.truetype(path, px)
        else:  # Pillow's own font (a scalable one since Pillow 10.1)
            try:
                _FONTS[px] = ImageFont.load_default(px)
            except TypeError:  # pragma: no cover - older Pillow
                _FONTS[px] = ImageFont.load_default()
    return _FONTS[px]


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

        def proper(lim):  # a view of zero width (a one-frame take) is widened to one unit, as matplotlib does
            lo, hi = float(lim[0]), float(lim[1])
            return (lo, hi) if hi > lo else (lo - 0.5, lo + 0.5)

        return proper(self.xlim or auto(xs)), proper(self.ylim or auto(ys))

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

        s = SUPERSAMPLE
        w, h = self.size_px
        canvas = PILImage.new("RGB", (w * s, h * s), "white")
        painter = _Painter(canvas, self.dpi * s / 72.0)
        for ax in self.axes:
            painter.axes(ax)
        return canvas.reduce(s) if s > 1 else canvas

    def save(self, file) -> None:
        """Write the PNG to ``file`` (a path or a binary file object)."""
        self.render().save(file, format="PNG", compress_level=3)


class _Painter:
    """Draws axes on a Pillow canvas; ``pt`` pixels per point."""

    def __init__(self, canvas, pt: float):
        from PIL import ImageDraw

        self.canvas, self.pt = canvas, pt
        self.draw = ImageDraw.Draw(canvas, "RGBA")

    def font(self, size_pt: float):
        return _font(max(1, round(size_pt * self.pt)))

    def box(self, ax: Axes) -> tuple[int, int, int, int]:
        """Pixel box (left, top, right, bottom) of the axes."""
        W, H = self.canvas.size
        l, b, w, h = ax.rect
        return round(l * W), round((1 - b - h) * H), round((l + w) * W), round((1 - b) * H)

    def axes(self, ax: Axes) -> None:
        from PIL import ImageDraw

        x0, y0, x1, y1 = self.box(ax)
        (xa, xb), (ya, yb) = ax.limits()
        sx, sy = (x1 - x0) / (xb - xa), (y1 - y0) / (yb - ya)

        def X(x):
            return (np.asarray(x, dtype=float) - xa) * sx

        def Y(y):
            return (y1 - y0) - (np.asarray(y, dtype=float) - ya) * sy

        # the data, drawn into the axes' own region of the canvas: clipped at its edges
        layer = self.canvas.crop((x0, y0, x1, y1))
        draw = ImageDraw.Draw(layer, "RGBA")
        for sp in ax.spans:
            fill = tuple(sp.color) + (round(255 * sp.alpha),)
            for a, b in sp.ranges:
                pa, pb = float(X(a)), float(X(b))
                if pb >= 0 and pa <= x1 - x0:
                    draw.rectangle([max(pa, -1), 0, min(pb, x1 - x0 + 1), y1 - y0], fill=fill)
        for im in ax.images:
            layer.paste(self._image(im, x1 - x0, y1 - y0, xa, xb, ya, yb), (0, 0), None)
        for ln in ax.lines:
            self._line(draw, X(ln.x), Y(ln.y), ln, x1 - x0)
        for e in ax.errorbars:
            px, py, lo, hi = X(e.x), Y(e.y), Y(e.y - e.yerr), Y(e.y + e.yerr)
            col, lw, cap, r = tuple(e.color) + (255,), max(1, round(e.lw * self.pt)), e.capsize * self.pt, e.ms * self.pt / 2
            for u, v, a, b in zip(px, py, lo, hi):
                draw.line([(u, a), (u, b)], fill=col, width=lw)
                draw.line([(u - cap, a), (u + cap, a)], fill=col, width=lw)
                draw.line([(u - cap, b), (u + cap, b)], fill=col, width=lw)
                draw.ellipse([u - r, v - r, u + r, v + r], fill=col)
        self.canvas.paste(layer, (x0, y0))
        frame = max(1, round(0.8 * self.pt))
        self.draw.rectangle([x0 - frame // 2, y0 - frame // 2, x1 + (frame - 1) // 2, y1 + (frame - 1) // 2],
                            outline=(0, 0, 0), width=frame)
        self._ticks(ax, (x0, y0, x1, y1), X, Y)
        if ax.legend_size:
            self._legend(ax, x0, y0)

    def _image(self, im: Image, w: int, h: int, xa, xb, ya, yb):
        """The image resampled onto the axes' ``w`` x ``h`` pixels (nearest sample); white outside it."""
        from PIL import Image as PILImage

        rows, cols = im.data.shape
        left, right, bottom, top = im.extent
        if not right > left:  # one sample of no width (a one-frame band): half a unit each side
            left, right = left - 0.5, left + 0.5
        if not top > bottom:
            bottom, top = bottom - 0.5, bottom + 0.5
        xs = xa + (np.arange(w) + 0.5) / w * (xb - xa)
        ys = yb - (np.arange(h) + 0.5) / h * (yb - ya)  # top pixel row first
        ci = np.floor((xs - left) / (right - left) * cols).astype(np.intp)
        ri = np.floor((ys - bottom) / (top - bottom) * rows).astype(np.intp)
        rgb = np.vstack([viridis(im.data, im.vmin, im.vmax), np.full((1, cols, 3), 255, np.uint8)])
        rgb = np.concatenate([rgb, np.full((rows + 1, 1, 3), 255, np.uint8)], axis=1)  # a white row and column
        ri = np.where((ri >= 0) & (ri < rows), ri, rows)  # outside the extent: the white row/column
        ci = np.where((ci >= 0) & (ci < cols), ci, cols)
        return PILImage.fromarray(np.ascontiguousarray(rgb[ri[:, None], ci[None, :]]), "RGB")

    def _line(self, draw, px, py, ln: Line, width_px: int) -> None:
        col = tuple(ln.color) + (round(255 * ln.alpha),)
        lw = max(1, round(ln.lw * self.pt))
        ok = np.isfinite(px) & np.isfinite(py)
        # runs of finite points; at most ~2 points per pixel column (a 72,000-frame map in a 400-pixel axes)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            step = max(1, (b - a) // max(2 * width_px, 1))
            idx = np.r_[np.arange(a, b, step), b - 1] if step > 1 else np.arange(a, b)
            pts = list(zip(px[idx].tolist(), py[idx].tolist()))
            if ln.dashed:
                for seg in _dashes(pts, 3.7 * ln.lw * self.pt, 1.6 * ln.lw * self.pt):
                    draw.line(seg, fill=col, width=lw)
            elif len(pts) > 1:
                draw.line(pts, fill=col, width=lw, joint="curve")

    def _text(self, xy, text: str, size_pt: float, anchor: str, *, rotate: bool = False) -> tuple[int, int]:
        """Draw ``text`` at ``xy`` (Pillow anchor); ``rotate``: reading upwards. Returns its (w, h)."""
        from PIL import Image as PILImage
        from PIL import ImageDraw

        font = self.font(size_pt)
        if not rotate:
            self.draw.text(xy, text, fill=(0, 0, 0), font=font, anchor=anchor)
            l, t, r, b = self.draw.textbbox(xy, text, font=font, anchor=anchor)
            return r - l, b - t
        l, t, r, b = font.getbbox(text)
        tile = PILImage.new("L", (r - l + 2, b - t + 2), 0)
        ImageDraw.Draw(tile).text((1 - l, 1 - t), text, fill=255, font=font)
        tile = tile.transpose(PILImage.Transpose.ROTATE_90)
        w, h = tile.size
        x, y = xy
        x = x - w if anchor[0] == "r" else x - w // 2 if anchor[0] == "m" else x  # anchor's first letter: horizontal
        y = y - h // 2
        self.canvas.paste((0, 0, 0), (round(x), round(y)), tile)
        return w, h

    def _ticks(self, ax: Axes, box, X, Y) -> None:
        x0, y0, x1, y1 = box
        tl, pad, lw = 3.5 * self.pt, 3.5 * self.pt, max(1, round(0.8 * self.pt))
        k = (0, 0, 0)
        xt = ax.xticks()
        for t, s in zip(xt, tick_labels(xt)):
            u = x0 + float(X(t))
            self.draw.line([(u, y1), (u, y1 + tl)], fill=k, width=lw)
            self._text((u, y1 + tl + pad), s, ax.tick_size, "mt")
        yt = ax.yticks()
        widest = 0
        labels = tick_labels(yt)
        size = ax.tick_size if not ax.ticks_right else ax.label_size + 2
        for t, s in zip(yt, labels):
            v = y0 + float(Y(t))
            if ax.ticks_right:
                self.draw.line([(x1, v), (x1 + tl, v)], fill=k, width=lw)
                w, _ = self._text((x1 + tl + pad, v), s, size, "lm")
            else:
                self.draw.line([(x0 - tl, v), (x0, v)], fill=k, width=lw)
                w, _ = self._text((x0 - tl - pad, v), s, size, "rm")
            widest = max(widest, w)
        mid = (y0 + y1) / 2
        if ax.ylabel:
            if ax.ticks_right:
                self._text((x1 + tl + pad + widest + 4 * self.pt, mid), ax.ylabel, ax.label_size, "lm", rotate=True)
            else:
                self._text((x0 - tl - pad - widest - 4 * self.pt, mid), ax.ylabel, ax.label_size, "rm", rotate=True)
        if ax.xlabel:
            th = self.font(ax.tick_size).getbbox("0")[3] if len(xt) else 0
            self._text(((x0 + x1) / 2, y1 + tl + pad + th + 4 * self.pt), ax.xlabel, ax.label_size, "mt")
        if ax.title:
            xy, anchor = ((x0, y0 - 6 * self.pt), "ld") if ax.title_loc == "left" else (((x0 + x1) / 2, y0 - 6 * self.pt), "md")
            self._text(xy, ax.title, ax.title_size, anchor)

    def _legend(self, ax: Axes, x0: int, y0: int) -> None:
        entries = [(ln.label, ln) for ln in ax.lines if ln.label] + [(sp.label, sp) for sp in ax.spans if sp.label]
        if not entries:
            return
        font, pt = self.font(ax.legend_size), self.pt
        line_h = ax.legend_size * 1.25 * pt
        sample = 2.0 * ax.legend_size * pt
        text_w = max(font.getbbox(label)[2] for label, _ in entries)
        pad = 0.4 * ax.legend_size * pt
        bx0, by0 = x0 + pad * 2, y0 + pad * 2
        bx1 = bx0 + pad * 3 + sample + text_w
        by1 = by0 + pad * 2 + line_h * len(entries)
        self.draw.rounded_rectangle([bx0, by0, bx1, by1], radius=pad, fill=(255, 255, 255, 204),
                                    outline=(204, 204, 204, 255), width=max(1, round(0.8 * pt)))
        for k, (label, el) in enumerate(entries):
            cy = by0 + pad + line_h * (k + 0.5)
            sx0, sx1 = bx0 + pad, bx0 + pad + sample
            if isinstance(el, Line):
                col, lw = tuple(el.color) + (round(255 * el.alpha),), max(1, round(el.lw * pt))
                segs = _dashes([(sx0, cy), (sx1, cy)], 3.7 * el.lw * pt, 1.6 * el.lw * pt) if el.dashed else [[(sx0, cy), (sx1, cy)]]
                for seg in segs:
                    self.draw.line(seg, fill=col, width=lw)
            else:
                self.draw.rectangle([sx0, cy - 0.35 * line_h, sx1, cy + 0.35 * line_h],
                                    fill=tuple(el.color) + (round(255 * el.alpha),))
            self.draw.text((sx1 + pad, cy), label, fill=(0, 0, 0), font=font, anchor="lm")


def _dashes(pts: list, on: float, off: float) -> list[list]:
    """A polyline cut into dashes ``on`` pixels long with gaps ``off`` pixels long."""
    out, cur, pos, drawing = [], [pts[0]], 0.0, True
    limit = on
    for (xa, ya), (xb, yb) in zip(pts[:-1], pts[1:]):
        seg = math.hypot(xb - xa, yb - ya)
        t = 0.0
        while seg - t > limit - pos:
            t += limit - pos
            p = (xa + (xb - xa) * t / seg, ya + (yb - ya) * t / seg)
            if drawing:
                cur.append(p)
                out.append(cur)
            cur = [p]
            drawing, pos, limit = not drawing, 0.0, off if drawing else on
        pos += seg - t
        if drawing:
            cur.append((xb, yb))
    if drawing and len(cur) > 1:
        out.append(cur)
    return out
