"""Evidence that the two takes show the same performance: the alignment against one with the
hands take played backwards.

DTW always returns a path, and on two takes of *different* performances (a wrong file, a
take of another session) it finds one whose cost is as low as warping allows: the cheap cells
of a random cost landscape.  The path's own spread does not show it: the best path through
noise is still the best by some margin.  What shows it is a null alignment: the same pass 1,
with the same options, between the body and the hands take played backwards.  That take moves
like the hands take (same speeds, same poses) but performs nothing of the body's in order, so
its cost is what the pass reaches on unrelated material.  The ratio of the two costs is near
1 for unrelated takes and well below for a genuine pair (README, *Real sessions*).

Both passes run at a coarse rate (:data:`CHECK_FPS`, lowered for long takes so that a pass
searches at most :data:`MAX_CHECK_CELLS` cells) without pins: cheap next to pass 1, and the
same for both, so the ratio compares like with like.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..rig.markers import Markers
from .paths import resample_markers

__all__ = ["CHECK_FPS", "MAX_CHECK_CELLS", "Evidence", "played_backwards", "match_evidence"]

#: Rate of the check's two passes, frames per second.
CHECK_FPS = 10.0
#: Cap on the cells one of the check's passes searches: the rate is lowered for long takes (a 20-minute
#: body at 60 fps: 3.1 fps, 2.0 s for the check).
MAX_CHECK_CELLS = 1 << 22


@dataclass(frozen=True)
class Evidence:
    """Pass 1's cost on the takes and on the hands take played backwards, at the check's rate.

    Attributes
    ----------
    cost, backwards_cost : float
        Total cost of each pass (local-cost units; open ends: uncovered frames' penalties included),
        over the same body frames.
    fps : float
        The rate both passes ran at.
    """

    cost: float
    backwards_cost: float
    fps: float

    @property
    def ratio(self) -> float:
        """``cost / backwards_cost``: near 1 when the takes may not show the same performance; NaN
        when the backwards pass cost nothing."""
        return self.cost / self.backwards_cost if self.backwards_cost > 0 else math.nan


def played_backwards(markers: Markers) -> Markers:
    """The same markers in reverse time order (frame ``k`` becomes frame ``T - 1 - k``)."""
    return Markers(markers.points[::-1], markers.shoulder[::-1], markers.heading[::-1], markers.up, markers.fps,
                   markers.side)


def match_evidence(body: Markers, hands: Markers, *, ends: str, others=(), fps: float = CHECK_FPS,
                   max_cells: int = MAX_CHECK_CELLS, progress=None, **options) -> Evidence:
    """Pass 1 on ``body``/``hands`` and on ``body``/``hands`` played backwards, at a coarse rate.

    Parameters
    ----------
    body, hands : Markers
        At a common rate (the splice's), as pass 1 gets them.
    ends : {"fixed", "open"}
        The end conditions pass 1 used: open ends let both passes skip what does not match.
    others : sequence of Arm
        More arms, as :func:`splicer.align.passes.pass1` takes them (their hands are played
        backwards too).
    fps : float
        The check's rate (lowered to the takes' rate, and for long takes so that a pass
        searches at most ``max_cells`` cells).
    progress : callable, optional
        ``progress(fraction)`` as the two passes go.
    **options
        More :func:`~splicer.align.passes.pass1` options (``smooth_s``, ``dead_zone``,
        ``sign_ramp``, ``theta``, ``position_weight``, ``uncovered_quantile``); pins are
        left out on purpose: played backwards, they would pin nonsense.

    Returns
    -------
    Evidence
    """
    from .passes import Arm, pass1

    if ends not in ("fixed", "open"):
        raise ValueError(f"ends must be 'fixed' or 'open', got {ends!r}")
    if body.fps != hands.fps:
        raise ValueError(f"body and hands markers must share a rate, got {body.fps:g} and {hands.fps:g} fps")
    n, m = body.n_frames, hands.n_frames
    top = rate = min(float(fps), float(body.fps))
    share = 0.3  # fixed ends: the paper's band, 30 % of the body take
    # cells of one pass at ``rate``: the band (fixed ends) or the whole matrix the open-ended locating pass searches
    cells = (share * n * n if ends == "fixed" else float(n) * m) * (rate / body.fps) ** 2
    if cells > max_cells:
        rate *= math.sqrt(max_cells / cells)

    def down(x: Markers) -> Markers:  # in two steps: one long anti-aliasing kernel over an hour of frames is slow
        return resample_markers(resample_markers(x, top), rate)

    b = down(body)
    hs = down(hands)
    arms0 = [(down(a.body), down(a.hands), a) for a in others]
    width = max(3.0, share * b.n_frames) if ends == "fixed" else max(3.0, 3.0 * rate)
    costs = []
    for k, turn in enumerate((lambda x: x, played_backwards)):
        arms = tuple(Arm(ab, turn(ah), a.smooth_s, a.position_weight) for ab, ah, a in arms0)
        step = None if progress is None else (lambda f, k=k: progress((k + f) / 2.0))
        p = pass1(b, turn(hs), width=width, ends=ends, others=arms, progress=step, **options)
        costs.append(float(p.cost))
    return Evidence(costs[0], costs[1], rate)
