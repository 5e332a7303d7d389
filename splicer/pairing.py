"""Which hands take belongs to which body take: a coarse alignment cost for every candidate pair.

For each take, once: its skeleton roles and each side's virtual markers brought down to a
coarse rate (``fps``, 5 frames per second by default).  For each (hands, body) candidate:
pass 1 of the splice (the phase metric D1, banded DTW around the diagonal, a band of 60 %
of the body take: a capture re-timed by 0.5x-2x needs the room) on those coarse markers,
per side both takes have, and the cost **per path step** (D1 is 0..96 per step, so takes
of different lengths compare), averaged over the sides.  The true partner
performs the same gestures in the same order and scores far below any other take.

Decision (:func:`decide_pairs`): a hands take is paired with body take ``b`` when ``b`` is
its cheapest body, it is ``b``'s cheapest hands take, and both runners-up cost at least
``margin`` more, relatively: ``(second - best) / second >= margin``.  Anything else is
refused with the reason (ambiguous, contested, no common side, unreadable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["TakeSignature", "take_signature", "pair_cost", "PairDecision", "decide_pairs", "cost_table_markdown"]

#: Default relative margin between the best and the second-best candidate.
DEFAULT_MARGIN = 0.15


@dataclass(frozen=True, eq=False)
class TakeSignature:
    """A take reduced to what pairing needs.

    Attributes
    ----------
    path : str
    markers : dict of str to Markers
        Per side found, the side's markers at ``fps`` frames per second, vertical axis Y-like
        axis of the take (``up``).
    up : int
    duration_s : float
        Seconds from the first to the last frame.
    error : str or None
        Why the take cannot be paired (unreadable, no arm or hand found); then ``markers`` is empty.
    """

    path: str
    markers: dict
    up: int
    duration_s: float
    error: str | None = None


def take_signature(path, *, fps: float = 5.0, hands_side: str | None = None) -> TakeSignature:
    """Read ``path`` and compute its coarse markers per side (never raises for bad input)."""
    from .align.passes import resample_markers
    from .io.bvh import read_bvh
    from .errors import SplicerError
    from .rig.markers import arm_markers
    from .rig.roles import FINGERS, find_roles

    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            motion = read_bvh(path)
        roles = find_roles(motion.skeleton, source=str(path), side=hands_side)
        markers = {}
        for s, arm in roles.sides.items():
            if arm.elbow is None and not any(f in arm.fingers for f in FINGERS):
                continue
            try:
                markers[s] = resample_markers(arm_markers(motion, arm, roles.up), fps)
            except SplicerError:
                continue
        if not markers:
            raise SplicerError(f"{path}: no arm or hand found to compare")
        return TakeSignature(str(path), markers, roles.up, (motion.n_frames - 1) / motion.fps)
    except SplicerError as e:
        return TakeSignature(str(path), {}, 1, math.nan, str(e))


def pair_cost(body: TakeSignature, hands: TakeSignature, *, band: str = "60%") -> float:
    """Mean pass-1 cost per path step over the sides both takes have (NaN: nothing to compare).

    Parameters
    ----------
    body, hands : TakeSignature
        At the same coarse rate.
    band : str or float
        Pass-1 band width (see :func:`splicer.band.band_frames`).

    Returns
    -------
    float
        D1 per step, 0..96 (squared sign differences of 24 components).
    """
    from .align.passes import pass1
    from .align.band import band_frames
    from .errors import SplicerError
    from .pipeline import _align_up

    costs = []
    for s in sorted(set(body.markers) & set(hands.markers)):
        b = body.markers[s]
        h = _align_up(hands.markers[s], body.up)
        if b.n_frames < 3 or h.n_frames < 3:
            continue
        try:
            p = pass1(b, h, width=band_frames(band, n=b.n_frames, fps=b.fps))
        except SplicerError:
            continue
        costs.append(p.cost / len(p.path))
    return float(np.mean(costs)) if costs else math.nan


@dataclass(frozen=True)
class PairDecision:
    """The pairing verdict for one hands take.

    Attributes
    ----------
    hands : str
    body : str or None
        The paired body take, or None when refused.
    cost, second : float
        Its cost and the runner-up's (NaN when there is none).
    margin : float
        ``(second - cost) / second``; the smaller of the two directions (other bodies for
        this hands take, other hands takes for this body).
    reason : str
        ``"paired"`` or why not.
    """

    hands: str
    body: str | None
    cost: float
    second: float
    margin: float
    reason: str


def _margin(best: float, second: float) -> float:
    if not math.isfinite(second):
        return math.inf
    return (second - best) / second if second > 0 else 0.0


def decide_pairs(costs: np.ndarray, bodies: list[str], hands: list[str], *, margin: float = DEFAULT_MARGIN,
                 max_cost: float | None = None) -> list[PairDecision]:
    """Mutual-best pairs whose runners-up are at least ``margin`` (relative) more expensive.

    Parameters
    ----------
    costs : np.ndarray [shape=(len(hands), len(bodies))]
        Cost per path step; NaN where a pair cannot be compared.
    bodies, hands : list of str
        Names (paths) of the columns and rows.
    margin : float
        Least relative gap between the best and second-best candidate, 0..1.
    max_cost : float, optional
        Refuse a best candidate costing more (per step); useful when a take has no
        runner-up (one body take only) to compare with.

    Returns
    -------
    list of PairDecision
        One per hands take, in row order.
    """
    costs = np.asarray(costs, dtype=np.float64)
    out = []
    for i, h in enumerate(hands):
        row = costs[i]
        ok = np.flatnonzero(np.isfinite(row))
        if not len(ok):
            out.append(PairDecision(h, None, math.nan, math.nan, math.nan, "no body take could be compared"))
            continue
        order = ok[np.argsort(row[ok], kind="stable")]
        j = int(order[0])
        best = float(row[j])
        second = float(row[order[1]]) if len(order) > 1 else math.inf
        col = costs[:, j]
        others = np.delete(col, i)
        others = others[np.isfinite(others)]
        col_second = float(others.min()) if len(others) else math.inf
        if col_second < best:
            k = int(np.flatnonzero(col == col_second)[0])
            out.append(PairDecision(h, None, best, second, -math.inf,
                                    f"contested: its best body {Path(bodies[j]).name} matches "
                                    f"{Path(hands[k]).name} better ({col_second:.3g} < {best:.3g})"))
            continue
        if max_cost is not None and best > max_cost:
            out.append(PairDecision(h, None, best, second, math.nan,
                                    f"too expensive: best {Path(bodies[j]).name} costs {best:.3g} > {max_cost:g}"))
            continue
        mg = min(_margin(best, second), _margin(best, col_second))
        second_shown = min(second, col_second)
        if mg < margin:
            out.append(PairDecision(h, None, best, second_shown, mg,
                                    f"ambiguous: best {Path(bodies[j]).name} {best:.3g}, runner-up "
                                    f"{second_shown:.3g} (margin {100 * mg:.0f}% < {100 * margin:.0f}%)"))
            continue
        out.append(PairDecision(h, bodies[j], best, second_shown, mg, "paired"))
    return out


def cost_table_markdown(costs: np.ndarray, bodies: list[str], hands: list[str]) -> str:
    """The cost table as markdown: one row per hands take, one column per body take."""
    names = [Path(b).stem for b in bodies]
    lines = ["| hands \\ body | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names)]
    for i, h in enumerate(hands):
        row = costs[i]
        best = np.nanmin(row) if np.isfinite(row).any() else math.nan
        cells = [("**%.3g**" if v == best else "%.3g") % v if math.isfinite(v) else "-" for v in row]
        lines.append(f"| {Path(h).stem} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
