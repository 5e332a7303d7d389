"""Band widths as users write them: frames (120), a share of the body take ("30%") or seconds
("20s"), turned into frames (one policy for the CLI, the API and the constraints file).
"""

from __future__ import annotations

import math
import re

from ..errors import ConstraintError

__all__ = ["band_frames", "pass_widths"]


def band_frames(width, *, n: int, fps: float | None = None) -> float:
    """Convert a band width specification to frames of the first sequence.

    The policy, one rule per kind of value (no cliff at 1):

    * a number (``int`` or ``float``) or a plain number string (``"120"``, ``"120f"``):
      **frames**, at least 1 (a band narrower than one frame is no band).  Numbers below 1
      are refused, not read as a share of the take: that reading made ``0.999`` mean 599
      frames of a 600-frame take while ``1`` meant one frame.
    * ``"30%"``: a **share** of the first sequence's length ``n``.
    * ``"20s"``, ``"1.5s"``: **seconds** at ``fps``.

    Parameters
    ----------
    width : int, float or str
        See above.
    n : int
        Length of the first sequence, frames.
    fps : float, optional
        Frame rate of the first sequence, frames per second; required for seconds.

    Returns
    -------
    float
        ``W`` in frames of the first sequence (> 0).

    Raises
    ------
    ConstraintError
        Malformed or non-positive width, a number below one frame, or seconds without ``fps``.

    Examples
    --------
    >>> band_frames(120, n=600), band_frames("30%", n=600), band_frames("2s", n=600, fps=60)
    (120.0, 180.0, 120.0)
    """
    if isinstance(width, bool):
        raise ConstraintError(f"band width must be a number or string, got {width!r}")
    spec = width
    if isinstance(width, str):
        s = width.strip().lower()
        mo = re.fullmatch(r"([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)\s*(%|s|f)?", s)
        if mo is None:
            raise ConstraintError(
                f"cannot parse band width {width!r}: use frames ('120'), a percentage of the "
                f"body length ('30%') or seconds ('20s')")
        value, unit = float(mo.group(1)), mo.group(2)
        if not value > 0:
            raise ConstraintError(f"band width {width!r} must be positive")
        if unit == "%":
            return value / 100.0 * n
        if unit == "s":
            if fps is None:
                raise ConstraintError(
                    f"band width {width!r} is in seconds but no frame rate (fps) is known")
            if not (fps > 0 and math.isfinite(fps)):
                raise ConstraintError(f"fps must be positive and finite, got {fps!r}")
            return value * float(fps)
        width = value
    try:
        w = float(width)
    except (TypeError, ValueError):
        raise ConstraintError(f"band width must be a number or string, got {width!r}") from None
    if not (w > 0 and math.isfinite(w)):
        raise ConstraintError(f"band width must be positive and finite, got {spec!r}")
    if w < 1:
        raise ConstraintError(
            f"band width {spec!r} is less than one frame: numbers are frames; write a share of "
            f"the body take as a percentage ('{100 * w:g}%') or seconds as '20s'")
    return w


def pass_widths(band1, band2, *, n: int, fps: float, open_ends: bool, guided: bool) -> tuple[float, float]:
    """Pass-1 and pass-2 band widths in body frames: the user's, else the defaults' policy.

    * ``band1`` None: :data:`splicer.defaults.OPEN_BAND1` (3 s around the located overlap) with
      open ends; :data:`splicer.defaults.GUIDED_BAND1` (4 s around the coarse guide's path) for
      a guided long take with fixed ends; else :data:`splicer.defaults.BAND1` (30 %, the paper).
    * ``band2`` None: a third of :data:`splicer.defaults.GUIDED_BAND2_OF` (20 s) when pass 1
      took the guided default, else ``band1`` times :data:`splicer.defaults.BAND2_PER_BAND1` (a third, the paper's 30 %
      and 10 %).

    Parameters
    ----------
    band1, band2 : int, float, str or None
        As :func:`band_frames` takes them; None for the default.
    n : int
        Body frames.
    fps : float
        Body frame rate, frames per second.
    open_ends : bool
        Pass 1 is open-ended.
    guided : bool
        Pass 1 runs the coarse guide pass first (ignored with open ends, whose locating pass
        plays that part).

    Returns
    -------
    (float, float)
        ``(W1, W2)``, body frames.

    Examples
    --------
    >>> pass_widths(None, None, n=72000, fps=60.0, open_ends=False, guided=True)
    (240.0, 400.0)
    >>> pass_widths(None, None, n=600, fps=30.0, open_ends=False, guided=False)
    (180.0, 60.0)
    >>> pass_widths("20s", None, n=72000, fps=60.0, open_ends=False, guided=True)
    (1200.0, 400.0)
    """
    from .. import defaults as D

    guided_default = band1 is None and guided and not open_ends
    if band1 is None:
        band1 = D.OPEN_BAND1 if open_ends else (D.GUIDED_BAND1 if guided else D.BAND1)
    w1 = band_frames(band1, n=n, fps=fps)
    if band2 is not None:
        w2 = band_frames(band2, n=n, fps=fps)
    elif guided_default:
        w2 = band_frames(D.GUIDED_BAND2_OF, n=n, fps=fps) * D.BAND2_PER_BAND1
    else:
        w2 = w1 * D.BAND2_PER_BAND1
    return w1, w2
