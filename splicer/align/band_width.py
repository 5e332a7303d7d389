"""Band widths as users write them: frames (120), a share of the body take ("30%") or seconds
("20s"), turned into frames (one policy for the CLI, the API and the constraints file).
"""

from __future__ import annotations

import math
import re

from ..errors import ConstraintError

__all__ = ['band_frames']


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
