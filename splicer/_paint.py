"""Drawing a :class:`splicer._chart.Figure`'s axes on a Pillow image: the data clipped to each
axes' box, then its frame, ticks, labels, title and legend.  Lengths come in points and are
turned into pixels at the canvas' resolution; text is DejaVu Sans from matplotlib's data
(found without importing matplotlib), else Pillow's own font."""

from __future__ import annotations

import importlib.util
import math
import os

import numpy as np

from ._chart import Axes, Image, Line, tick_labels, viridis, widened
from .runs import true_runs

__all__ = ["Painter"]


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


def _rgba(color, alpha: float) -> tuple:
    return tuple(color) + (round(255 * alpha),)


class Painter:
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
            fill = _rgba(sp.color, sp.alpha)
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
            col, lw, cap, r = _rgba(e.color, 1.0), max(1, round(e.lw * self.pt)), e.capsize * self.pt, e.ms * self.pt / 2
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
        left, right = widened(left, right)  # one sample of no width (a one-frame band)
        bottom, top = widened(bottom, top)
        xs = xa + (np.arange(w) + 0.5) / w * (xb - xa)
        ys = yb - (np.arange(h) + 0.5) / h * (yb - ya)  # top pixel row first
        ci = np.floor((xs - left) / (right - left) * cols).astype(np.intp)
        ri = np.floor((ys - bottom) / (top - bottom) * rows).astype(np.intp)
        rgb = np.vstack([viridis(im.data, im.vmin, im.vmax), np.full((1, cols, 3), 255, np.uint8)])
        rgb = np.concatenate([rgb, np.full((rows + 1, 1, 3), 255, np.uint8)], axis=1)  # a white row and column
        ri = np.where((ri >= 0) & (ri < rows), ri, rows)  # outside the extent: the white row/column
        ci = np.where((ci >= 0) & (ci < cols), ci, cols)
        return PILImage.fromarray(np.ascontiguousarray(rgb[ri[:, None], ci[None, :]]), "RGB")

    def _stroke(self, draw, pts: list, ln: Line) -> None:
        """``pts`` (pixels) drawn in ``ln``'s colour, width and dashes."""
        col, lw = _rgba(ln.color, ln.alpha), max(1, round(ln.lw * self.pt))
        if ln.dashed:
            for seg in _dashes(pts, 3.7 * ln.lw * self.pt, 1.6 * ln.lw * self.pt):  # matplotlib's "--"
                draw.line(seg, fill=col, width=lw)
        elif len(pts) > 1:
            draw.line(pts, fill=col, width=lw, joint="curve")

    def _line(self, draw, px, py, ln: Line, width_px: int) -> None:
        ok = np.isfinite(px) & np.isfinite(py)
        # runs of finite points; at most ~2 points per pixel column (a 72,000-frame map in a 400-pixel axes)
        for a, b in zip(*true_runs(ok)):
            step = max(1, (b - a) // max(2 * width_px, 1))
            idx = np.r_[np.arange(a, b, step), b - 1] if step > 1 else np.arange(a, b)
            self._stroke(draw, list(zip(px[idx].tolist(), py[idx].tolist())), ln)

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
        for t, s in zip(yt, tick_labels(yt)):
            v = y0 + float(Y(t))
            if ax.ticks_right:
                self.draw.line([(x1, v), (x1 + tl, v)], fill=k, width=lw)
                w, _ = self._text((x1 + tl + pad, v), s, ax.tick_size, "lm")
            else:
                self.draw.line([(x0 - tl, v), (x0, v)], fill=k, width=lw)
                w, _ = self._text((x0 - tl - pad, v), s, ax.tick_size, "rm")
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
                self._stroke(self.draw, [(sx0, cy), (sx1, cy)], el)
            else:
                self.draw.rectangle([sx0, cy - 0.35 * line_h, sx1, cy + 0.35 * line_h], fill=_rgba(el.color, el.alpha))
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
