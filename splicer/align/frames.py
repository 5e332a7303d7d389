"""Frame spaces of a splice, and the user's pins carried through them.

A splice works in four frame spaces; every conversion between them lives here:

* **body-file frames**: 0-based frames of the body take (``n_body`` frames at ``body_fps``).
  The alignment runs at this rate, so body-file frames are also the *common* rows.
* **hands-file frames**: 0-based frames of the hands take (``n_hands`` at ``hands_fps``).
  Pins, tolerances and the output time map are in these units.
* **common frames**: the hands take resampled to the body rate; frame ``k`` is at
  ``k / body_fps`` seconds, i.e. hands-file frame ``k * ratio`` with ``ratio = hands_fps /
  body_fps``.  Both DTW passes index hands frames in this space.
* **warped frames**: pass 2's second sequence, the hands resampled at pass 1's time map
  (one per body frame); mapped back through that map.

A :class:`Pin` keeps the user's numbers, file and line, so every message about it can
name them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .band import Constraint
from ..errors import ConstraintError

__all__ = ["Pin", "FrameSpaces", "pins_from_config"]


@dataclass(frozen=True)
class Pin:
    """One matching pair given by the animator, in file frames.

    Attributes
    ----------
    body : int
        0-based body-file frame.
    hands : int
        0-based hands-file frame shown at the same instant.
    tolerance : int
        ``T``: how far (hands-file frames) the time map may pass from ``hands`` at ``body``.
    where : str
        Where the user wrote it, e.g. ``"sync.yaml, line 7: pair 2"``.
    line : int or None
        1-based line in the constraints file.
    """

    body: int
    hands: int
    tolerance: int
    where: str
    line: int | None = None

    def describe(self) -> str:
        """``"sync.yaml, line 7: pair 2 (body 120, hands 251, tolerance 2)"``."""
        return f"{self.where} (body {self.body}, hands {self.hands}, tolerance {self.tolerance})"


@dataclass(frozen=True)
class FrameSpaces:
    """Sizes and rates of one splice, and the conversions between its frame spaces.

    Parameters
    ----------
    n_body, n_hands : int
        Frames of each file.
    body_fps, hands_fps : float
        Frames per second of each file.
    """

    n_body: int
    n_hands: int
    body_fps: float
    hands_fps: float

    @property
    def ratio(self) -> float:
        """Hands-file frames per common frame (``hands_fps / body_fps``)."""
        return self.hands_fps / self.body_fps

    def hands_to_common(self, frames):
        """Hands-file frames -> common frames (fractional)."""
        return np.asarray(frames, dtype=np.float64) / self.ratio

    def common_to_hands(self, frames):
        """Common frames -> hands-file frames (fractional)."""
        return np.asarray(frames, dtype=np.float64) * self.ratio

    def hands_seconds(self, frames):
        """Hands-file frames -> seconds from the hands take's first frame."""
        return np.asarray(frames, dtype=np.float64) / self.hands_fps

    def body_seconds(self, frames):
        """Body-file frames -> seconds from the body take's first frame."""
        return np.asarray(frames, dtype=np.float64) / self.body_fps

    def dtw_constraints(self, pins, m_common: int, *, open_ends: bool = False) -> list[Constraint]:
        """The pins as DTW constraints between body frames and common hands frames.

        The hands frame is rounded to the nearest common frame and the tolerance widened to
        cover that rounding (``ceil(T / ratio + r)``, ``r`` the rounding distance), so a pin
        that holds at the file rate is never refused at the common rate.  Two pins that round
        onto the same common frame keep it (a path may stay on one hands frame).  With fixed
        ends, a pin on the first or last body frame must agree with the path's end points
        (within its tolerance) and is then implied by them.

        Raises
        ------
        ConstraintError
            A pin on a first/last frame that contradicts fixed end points, naming the pin.
        """
        n = self.n_body
        out: list[Constraint] = []
        kept: list[int] = []
        for k, p in enumerate(pins):
            yf = p.hands / self.ratio
            y = int(round(yf))
            t = int(math.ceil(p.tolerance / self.ratio + abs(y - yf) - 1e-9))
            if not open_ends and (p.body in (0, n - 1) or y <= 0 or y >= m_common - 1):
                ends_ok = (p.body == 0 and y <= t) or (p.body == n - 1 and y >= m_common - 1 - t)
                if not ends_ok:
                    raise ConstraintError(
                        f"{p.describe()} conflicts with fixed end points: with --ends fixed the first frames "
                        "of both takes match each other, and so do the last frames")
                continue
            if p.body in (0, n - 1):
                continue  # an open end at a pinned first/last row: the time map enforces it
            y = min(max(y, 1), m_common - 2)
            if out and y < out[-1].y:
                y = out[-1].y
            if out and p.body == out[-1].x + 1 and (y - t) - (out[-1].y + out[-1].tolerance) > 1:
                err = ConstraintError(f"{p.describe()} cannot follow {pins[kept[-1]].describe()}: adjacent body "
                                      "frames cannot match hands frames further apart than their tolerances allow")
                err.pair = (kept[-1], k)
                raise err
            out.append(Constraint(p.body, y, t))
            kept.append(k)
        return out


def pins_from_config(cfg, side: str, spaces: FrameSpaces) -> tuple[Pin, ...]:
    """The constraints file's pairs for ``side``, checked and converted to file frames.

    Raises
    ------
    ConstraintError
        A time that cannot be read, a frame outside its take, or pairs that do not increase
        in both files; the message names the file, line and pair.
    """
    from ..io.config import frame_number

    out: list[Pin] = []
    for p in cfg.pairs:
        if p.side not in (side, "both"):
            continue
        where = f"{cfg.source}, line {p.line}: pair {p.index + 1}"
        x = frame_number(p.body, spaces.body_fps, what=f"{where}, body")
        y = frame_number(p.hands, spaces.hands_fps, what=f"{where}, hands")
        tol_spec = cfg.tolerance if p.tolerance is None else p.tolerance
        t = frame_number(tol_spec, spaces.hands_fps, what=f"{where}, tolerance")
        if not 0 <= x < spaces.n_body:
            raise ConstraintError(f"{where}: body frame {x} is outside the body take (frames 0..{spaces.n_body - 1})")
        if not 0 <= y < spaces.n_hands:
            raise ConstraintError(
                f"{where}: hands frame {y} is outside the hands take (frames 0..{spaces.n_hands - 1})")
        out.append(Pin(x, y, t, where, p.line))
    for a, b in zip(out, out[1:]):
        if not (b.body > a.body and b.hands > a.hands):
            raise ConstraintError(
                f"{b.where}: pairs must increase in both files: (body {a.body}, hands {a.hands}) at line "
                f"{a.line} is followed by (body {b.body}, hands {b.hands})")
    return tuple(out)
