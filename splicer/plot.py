"""Pictures of an alignment: per side, each pass's local costs inside its band, the user's
constraint windows and the chosen path.

Drawn with :mod:`splicer._chart` on Pillow (matplotlib's import alone took most of issue 12's
0.5 s for a plot): no process state, no global figure list.  Each pass's band is one
image (the local costs sampled on at most ``max_pixels`` per side), so a plot of a long take
costs no more than a short one."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ._chart import Figure
from .errors import SplicerError
from .io.atomic import write_atomic

__all__ = ["band_image", "figure", "plot_alignment"]

_MAX_PIXELS = 700
_WHITE, _RED, _ORANGE, _BLACK, _GRAY = (255, 255, 255), (255, 0, 0), (255, 165, 0), (0, 0, 0), (128, 128, 128)
_TAB_GRAY, _TAB_RED, _TAB_BLUE = (127, 127, 127), (214, 39, 40), (31, 119, 180)
_CELL_BUDGET = 4_000_000  # local costs computed at once for a band image (32 MB of float64)


def band_image(pass_result, *, max_pixels: int = _MAX_PIXELS) -> tuple[np.ndarray, float, float]:
    """Local costs of a pass on a grid of at most ``max_pixels`` per side; NaN outside the band.

    The local costs of a band of up to 4 million cells are computed in one call; longer takes
    are shown by sampling rows and columns (not by computing every cell again).

    Returns
    -------
    image : np.ndarray [shape=(rows, cols)]
    row_step, col_step : float
        Frames per pixel along each axis.
    """
    band = pass_result.band
    n, m = band.n, band.m
    rows = np.unique(np.linspace(0, n - 1, min(n, max_pixels)).round().astype(int))
    cols = np.unique(np.linspace(0, m - 1, min(m, max_pixels)).round().astype(int))
    img = np.full((len(rows), len(cols)), np.nan)
    if n * band.max_row_width <= _CELL_BUDGET:  # one call for the whole band (kernels start once)
        whole = pass_result.local_cost(band, 0, n)
        block = lambda i: whole[i]  # noqa: E731
    else:  # a long take: only the sampled rows
        block = lambda i: pass_result.local_cost(band, i, i + 1)[0]  # noqa: E731
    for r, i in enumerate(rows):
        vals = np.asarray(block(int(i)))
        lo, hi = int(band.lo[i]), int(band.hi[i])
        inside = (cols >= lo) & (cols <= hi)
        img[r, inside] = vals[cols[inside] - lo]
    return img, (n - 1) / max(len(rows) - 1, 1), (m - 1) / max(len(cols) - 1, 1)


def _draw_pass(ax, pr, title, constraints=(), *, max_pixels: int = _MAX_PIXELS, images: dict | None = None):
    """``images``: band images already computed, by pass (one pass 1 shared by both sides is sampled once)."""
    images = {} if images is None else images
    if id(pr) not in images:
        images[id(pr)] = band_image(pr, max_pixels=max_pixels)
    img, rs, cs = images[id(pr)]
    n, m = pr.band.n, pr.band.m
    im = ax.imshow(img.T, extent=(-0.5 * rs, (n - 1) + 0.5 * rs, -0.5 * cs, (m - 1) + 0.5 * cs))
    i = np.arange(n)
    ax.plot(i, pr.band.lo, _WHITE, 0.6, alpha=0.8)
    ax.plot(i, pr.band.hi, _WHITE, 0.6, alpha=0.8)
    ax.plot(pr.path[:, 0], pr.path[:, 1], _RED, 1.2)
    ax.errorbar([c.x for c in constraints], [c.y for c in constraints], [c.tolerance for c in constraints], _ORANGE)
    ax.title, ax.title_size, ax.title_loc = title, 9, "left"  # from the axes' left edge, over the colour bar
    ax.xlabel = "body frame"
    ax.xlim, ax.ylim = (0, n - 1), (0, m - 1)
    return im


def _spans(ranges) -> list[tuple[float, float]]:
    """``[first, last]`` frame ranges as ``(first - 0.5, last + 0.5)``: body frames, each ``[i - 0.5, i + 0.5]``."""
    return [(a - 0.5, b + 0.5) for a, b in ranges]


def _ranges(mask: np.ndarray) -> list[tuple[float, float]]:
    """The runs of ``mask`` as :func:`_spans`."""
    from .transfer.timemap import frame_ranges

    return _spans(frame_ranges(mask))


# Layout in inches of one side's cell (4.2 x 3.6 in): fixed rectangles (matplotlib's tight_layout, used
# once, measured every tick label of every axis, 0.3 s on the sample, to find what these say).
_CELL_W, _CELL_H = 4.2, 3.6
_LEFT, _BOTTOM, _TOP = 0.62, 0.5, 0.3  # y tick labels and label; x tick labels and label; title
_CBAR_GAP, _CBAR_W, _CBAR_LABELS = 0.06, 0.12, 0.78  # colorbar: gap, bar, its tick labels and label


def _rect(fig_w, fig_h, row, col, nrows, left, width):
    """``[left, bottom, width, height]`` in figure fractions of an axis ``left`` in from its cell's left edge."""
    x0 = col * _CELL_W + left
    y0 = (nrows - 1 - row) * _CELL_H + _BOTTOM
    return [x0 / fig_w, y0 / fig_h, width / fig_w, (_CELL_H - _BOTTOM - _TOP) / fig_h]


def plot_alignment(result, path: str | os.PathLike, *, dpi: int = 110) -> None:
    """Write a PNG of every side's passes (atomically: a temporary file, then rename).

    One row per side: each pass's local costs inside its band (one image each) with the band's
    edges, the chosen path and the pins, then the time map with the frames that have no hands
    material, the low-confidence frames and the body's holds (:mod:`splicer.align.holds`) shaded.

    Parameters
    ----------
    result : SpliceResult
    path : path of the PNG to write
    dpi : int
        Pixels per inch: the image is ``4.2 x (passes + 1)`` inches wide and ``3.6`` inches
        high per side.
    """
    fig = figure(result, dpi=dpi)
    write_atomic(Path(path), fig.save, what="plot")


def figure(result, *, dpi: int = 110) -> Figure:
    """The alignment plot of ``result`` as a scene, not yet drawn: :func:`plot_alignment` draws
    and writes it; tests read its axes (:class:`splicer._chart.Axes`)."""
    from .align.holds import hold_ranges
    from .align.passes import hold_ends, path_median, remap_constraints
    from .pipeline import LOW_CONFIDENCE_S
    from .stages.report import low_confidence_ranges

    sides = list(result.sides.values())
    if not sides:
        raise SplicerError("nothing to plot: no side was aligned")
    ncols = max(sum(p is not None for p in (s.pass1, s.pass2)) for s in sides) + 1
    nrows = len(sides)
    fig_w, fig_h = _CELL_W * ncols, _CELL_H * nrows
    fig = Figure(fig_w, fig_h, dpi)
    pass_left = map_left = _LEFT + 0.1  # four-digit hands frames and the axis label beside them
    pass_w = _CELL_W - pass_left - _CBAR_GAP - _CBAR_W - _CBAR_LABELS
    map_w = _CELL_W - map_left - 0.2
    # a band image of one sample per screen pixel (nearest-neighbour drawing shows no more), at most _MAX_PIXELS
    px = min(_MAX_PIXELS, math.ceil(dpi * max(pass_w, _CELL_H - _BOTTOM - _TOP)))

    def pass_axes(row, col):
        ax = fig.add_axes(_rect(fig_w, fig_h, row, col, nrows, pass_left, pass_w))
        cax = fig.add_axes(_rect(fig_w, fig_h, row, col, nrows, pass_left + pass_w + _CBAR_GAP, _CBAR_W))
        return ax, cax

    images: dict = {}  # band images by pass: a pass 1 shared by both sides is sampled once
    for row, s in enumerate(sides):
        n = len(s.hands_frame)
        cons = s.alignment.constraints
        k = 0
        if s.pass1 is not None:
            ax, cax = pass_axes(row, k)
            w = s.pass1.position_weight
            what = ("both arms, D1" if s.pass1.arms > 1 else "phase metric D1") + (" + positions" if w else "")
            im = _draw_pass(ax, s.pass1, f"{s.side}: pass 1, {what} (band {s.pass1.band.width:.0f} frames)", cons,
                            max_pixels=px, images=images)
            ax.ylabel = "hands frame (body rate)"
            fig.colorbar(im, cax, f"D1 + {w:g} x position term" if w else "D1 (squared sign differences)")
            k += 1
        if s.pass2 is not None:
            ax, cax = pass_axes(row, k)
            map1 = None if s.pass1 is None else hold_ends(path_median(s.pass1.path, n))
            c2 = cons if map1 is None else remap_constraints(cons, map1)
            im = _draw_pass(ax, s.pass2, f"{s.side}: pass 2, palm metric D2 (band {s.pass2.band.width:.0f} frames)", c2,
                            max_pixels=px)
            ax.ylabel = "warped hands frame" if s.pass1 is not None else "hands frame (body rate)"
            fig.colorbar(im, cax, "D2 + departure penalty (rad)")
            k += 1
        ax = fig.add_axes(_rect(fig_w, fig_h, row, ncols - 1, nrows, map_left, map_w))
        t = np.arange(n)
        ax.plot(t, s.hands_frame, _BLACK, 1.2, label="hands frame used")
        top = float(np.nanmax(s.hands_frame)) if np.isfinite(s.hands_frame).any() else 0.0
        ax.plot(t, np.linspace(0.0, top, n), _GRAY, 0.8, dashed=True, label="uniform time scaling")
        gaps = _ranges(~np.isfinite(s.hands_frame))
        if gaps:
            ax.axvspans(gaps, _TAB_GRAY, 0.2, "no hands material")
        conf = s.alignment.confidence
        if conf is not None:
            low = _spans(low_confidence_ranges(conf.est_error_s, s.markers.spaces.body_fps))
            if low:
                ax.axvspans(low, _TAB_RED, 0.2, f"low confidence (est. error > {LOW_CONFIDENCE_S:g} s)")
        holds = hold_ranges(getattr(s.pass1, "held_rows", None))  # align.holds
        if holds:
            ax.axvspans([(a - 0.5, b + 0.5) for a, b in holds], _TAB_BLUE, 0.15, "body holds still")
        ax.errorbar([p.body for p in s.pins], [p.hands for p in s.pins], [p.tolerance for p in s.pins], _ORANGE)
        ax.title, ax.title_size = f"{s.side}: time map", 9
        ax.xlabel, ax.ylabel = "body frame", "hands-file frame"
        ax.legend_size = 7
    return fig
