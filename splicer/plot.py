"""Pictures of an alignment: per side, each pass's local costs inside its band, the user's
constraint windows and the chosen path.

Drawn on a :class:`matplotlib.figure.Figure` with its own Agg canvas: no pyplot, no global
figure list, and the caller's matplotlib backend is left as it is.  Each pass's band is one
image (the local costs sampled on at most ``max_pixels`` per side), so a plot of a long take
costs no more than a short one."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .io.atomic import write_atomic
from .errors import SplicerError

__all__ = ["band_image", "plot_alignment"]

_MAX_PIXELS = 700
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


def _draw_pass(ax, pr, title, constraints=()):
    img, rs, cs = band_image(pr)
    n, m = pr.band.n, pr.band.m
    im = ax.imshow(img.T, origin="lower", aspect="auto", cmap="viridis", interpolation="nearest",
                   extent=(-0.5 * rs, (n - 1) + 0.5 * rs, -0.5 * cs, (m - 1) + 0.5 * cs))
    i = np.arange(n)
    ax.plot(i, pr.band.lo, color="white", lw=0.6, alpha=0.8)
    ax.plot(i, pr.band.hi, color="white", lw=0.6, alpha=0.8, label="band")
    ax.plot(pr.path[:, 0], pr.path[:, 1], color="red", lw=1.2, label="path")
    for c in constraints:
        ax.errorbar([c.x], [c.y], yerr=[[c.tolerance], [c.tolerance]], fmt="o", color="orange",
                    ms=4, capsize=3, lw=1.5)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("body frame")
    ax.set_xlim(0, n - 1)
    ax.set_ylim(0, m - 1)
    return im


def _shade(ax, mask: np.ndarray, color: str, label: str) -> None:
    """Shade the runs of ``mask`` (body frames) on a time-map axis, one legend entry."""
    from .transfer.timemap import frame_ranges

    for k, (a, b) in enumerate(frame_ranges(mask)):
        ax.axvspan(a - 0.5, b + 0.5, color=color, alpha=0.2, lw=0, label=label if k == 0 else None)


def plot_alignment(result, path: str | os.PathLike, *, dpi: int = 110) -> None:
    """Write a PNG of every side's passes (atomically: a temporary file, then rename).

    Parameters
    ----------
    result : SpliceResult
    path : path of the PNG to write
    dpi : int
        Pixels per inch: the image is ``4.2 x (passes + 1)`` inches wide and ``3.6`` inches
        high per side.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from .align.passes import hold_ends, path_median, remap_constraints
    from .pipeline import LOW_CONFIDENCE_S

    sides = list(result.sides.values())
    if not sides:
        raise SplicerError("nothing to plot: no side was aligned")
    ncols = max(sum(p is not None for p in (s.pass1, s.pass2)) for s in sides) + 1
    fig = Figure(figsize=(4.2 * ncols, 3.6 * len(sides)))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(sides), ncols, squeeze=False)
    for row, s in zip(axes, sides):
        n = len(s.hands_frame)
        cons = s.alignment.constraints
        k = 0
        if s.pass1 is not None:
            im = _draw_pass(row[k], s.pass1, f"{s.side}: pass 1, phase metric D1 (band {s.pass1.band.width:.0f} frames)", cons)
            row[k].set_ylabel("hands frame (body rate)")
            fig.colorbar(im, ax=row[k], fraction=0.046, pad=0.02).set_label("D1 (squared sign differences)", fontsize=8)
            k += 1
        if s.pass2 is not None:
            map1 = None if s.pass1 is None else hold_ends(path_median(s.pass1.path, n))
            c2 = cons if map1 is None else remap_constraints(cons, map1)
            im = _draw_pass(row[k], s.pass2, f"{s.side}: pass 2, palm metric D2 (band {s.pass2.band.width:.0f} frames)", c2)
            row[k].set_ylabel("warped hands frame" if s.pass1 is not None else "hands frame (body rate)")
            fig.colorbar(im, ax=row[k], fraction=0.046, pad=0.02).set_label("D2 + departure penalty (rad)", fontsize=8)
            k += 1
        ax = row[k]
        t = np.arange(n)
        ax.plot(t, s.hands_frame, color="black", lw=1.2, label="hands frame used")
        top = float(np.nanmax(s.hands_frame)) if np.isfinite(s.hands_frame).any() else 0.0
        ax.plot(t, np.linspace(0.0, top, n), color="gray", lw=0.8, ls="--", label="uniform time scaling")
        _shade(ax, ~np.isfinite(s.hands_frame), "tab:gray", "no hands material")
        conf = s.alignment.confidence
        if conf is not None:
            _shade(ax, np.isfinite(conf.est_error_s) & (conf.est_error_s > LOW_CONFIDENCE_S), "tab:red",
                   f"low confidence (est. error > {LOW_CONFIDENCE_S:g} s)")
        for p in s.pins:
            ax.errorbar([p.body], [p.hands], yerr=[[p.tolerance], [p.tolerance]], fmt="o", color="orange", ms=4, capsize=3)
        ax.set_title(f"{s.side}: time map", fontsize=9)
        ax.set_xlabel("body frame")
        ax.set_ylabel("hands-file frame")
        ax.legend(fontsize=7, loc="upper left")
        for extra in row[k + 1:]:
            extra.axis("off")
    fig.tight_layout()
    dest = Path(path)
    write_atomic(dest, lambda f: fig.savefig(f, dpi=dpi, format="png"), what="plot")
