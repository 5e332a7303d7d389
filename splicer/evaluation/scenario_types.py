"""What a scenario is (:class:`Scenario`, its components and names) and what it yields
(:class:`ScenarioSeparation`: the takes and their ground truth), with the error against that truth.

The takes are made by :func:`splicer.evaluation.scenarios.make_scenario`.

Time semantics.  Every frame of either take shows one instant of the original take, its
*take time* (fractional take frame; ``body_time``, ``hands_time``; NaN for extra material).
``truth[i]`` is the fractional hands frame showing body frame ``i``'s instant (linear in
the hands' take time between frames), NaN where no genuine hands frame covers it.  The
alignment error of a method that uses hands frame ``f`` for body frame ``i`` is the
distance between the two instants, ``|H(f) - body_time[i]| / take_fps`` seconds, where
``H`` interpolates ``hands_time`` and continues at the hands' rate into extra material (a
frame ``d`` hands frames before the genuine span counts as ``d / hands_fps`` seconds before
its first instant).  With neither pauses nor extra material this equals the error of
:mod:`splicer.evaluate` (body frames, mapped back through the inverse truth) divided by fps.
Inside a hands pause every held frame shows the same instant (any of them is right); inside
a body pause only the held instant's hands frame is right.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion

__all__ = ["Scenario", "COMPONENTS", "SCENARIOS", "ALL", "scenario", "ScenarioSeparation", "invert_time",
           "hands_take_time", "alignment_error_s"]


@dataclass(frozen=True)
class Scenario:
    """What makes the sessions differ; ``None`` switches a component off.

    Durations in seconds, speeds as ratios, rates in frames per second, angles in degrees.
    """

    name: str = "base"
    extra_begin_s: tuple[float, float] | None = None
    extra_end_s: tuple[float, float] | None = None
    still_share: tuple[float, float] = (0.3, 0.7)  # share of the extra material that is the still pose
    still_share_end: tuple[float, float] | None = None  # the same after the span; None: ``still_share``
    blend_s: float = 0.25  # easing of each junction of extra material, inside the extra material
    cover: tuple[float, float] | None = None  # share of the body's span the hands cover
    cover_start: float | None = None  # where that share starts (share of the take); None: random
    pause_hands_s: tuple[float, float] | None = None
    pause_body_s: tuple[float, float] | None = None
    warp_speed: tuple[float, float] = (0.5, 2.0)
    body_fps: float | None = None  # None: the take's rate
    hands_fps: float | None = None  # None: twice the take's rate
    imitation: bool = False
    imitation_amplitude: tuple[float, float] = (0.7, 1.3)
    wrist_drift_deg: float = 5.0
    arm_noise_deg: tuple[float, float] = (1.0, 2.0)


#: The components and the fields each sets.
COMPONENTS = {
    "extra-begin": {"extra_begin_s": (2.0, 8.0)},
    "extra-end": {"extra_end_s": (2.0, 8.0)},
    "extra": {"extra_begin_s": (2.0, 8.0), "extra_end_s": (2.0, 8.0)},
    "short": {"cover": (0.4, 0.8)},
    "clip": {"cover": (0.03, 0.1)},  # a short hand clip on a long body (not in SCENARIOS)
    "pause-hands": {"pause_hands_s": (1.0, 2.0)},
    "pause-body": {"pause_body_s": (1.0, 2.0)},
    "speed": {"warp_speed": (0.33, 3.0)},
    "rate": {"body_fps": 29.97, "hands_fps": 120.0},
    "imitation": {"imitation": True},
}

#: The named scenarios of ``splicer-evaluate --scenarios all`` (components joined by ``+``).
SCENARIOS = ("base", "extra", "short", "pause-hands", "pause-body", "speed", "rate", "imitation", "all")
#: ``"all"``: every component at once.
ALL = "extra+short+pause-hands+pause-body+speed+rate+imitation"


def scenario(name: str) -> Scenario:
    """The scenario named ``name``: ``"base"``, ``"all"``, or components joined by ``+``
    (e.g. ``"extra+pause-hands"``; see :data:`COMPONENTS`)."""
    if name == "all":
        name = ALL
    if name == "base":
        return Scenario("base")
    parts = [p.strip() for p in name.split("+") if p.strip()]
    bad = [p for p in parts if p not in COMPONENTS]
    if bad or not parts:
        raise SplicerError(f"unknown scenario {name!r}: use base, all, or components joined by '+' "
                           f"from {', '.join(COMPONENTS)}")
    kw: dict = {}
    for p in parts:
        kw.update(COMPONENTS[p])
    return Scenario("all" if name == ALL else name, **kw)


@dataclass(frozen=True, eq=False)
class ScenarioSeparation:
    """A take split into body and hands as two separate sessions would record it.

    Attributes
    ----------
    body : Motion
        Fingers at identity; ``n_b`` frames at ``body_fps``.
    hands : Motion
        The hand capture, ``m`` frames at ``hands_fps`` (extra material included).
    truth : np.ndarray [shape=(n_b,)]
        Fractional hands frame of each body frame; NaN where no hands material covers it.
    body_time : np.ndarray [shape=(n_b,)]
        Fractional take frame shown by each body frame.
    hands_time : np.ndarray [shape=(m,)]
        Fractional take frame shown by each hands frame; NaN in extra material.
    genuine : (int, int)
        First and last hands frame of the genuine span (inclusive).
    take_fps : float
    scenario : Scenario
    params : dict
        Drawn values (``extra_begin_frames``, ``extra_end_frames``, ``pause_hands`` (hands
        frame, K), ``pause_body`` (body frame, k), ``pause_windows`` (``[first, last]`` body
        frames from each pause's start to 3 s after its end), ``cover``, ``hands_fps``, ``body_fps``,
        the capture's draws, ``imitation`` draws).
    """

    body: Motion
    hands: Motion
    truth: np.ndarray
    body_time: np.ndarray
    hands_time: np.ndarray
    genuine: tuple[int, int]
    take_fps: float
    scenario: Scenario
    params: dict = field(default_factory=dict)

    @property
    def covered(self) -> np.ndarray:
        """Body frames some genuine hands frame covers, bool (n_b,)."""
        return np.isfinite(self.truth)


def invert_time(h: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Fractional index into the non-decreasing ``h`` at which ``h`` takes the values ``t``.

    Linear between samples; where ``h`` is flat at exactly ``t`` the last index of the flat;
    NaN outside ``[h[0], h[-1]]``, widened by a rounding tolerance of 1e-9 of the range's
    magnitude (numpy 1.26 sums a re-timing to 359.99999999999994 where numpy 2 gives 360).

    Examples
    --------
    >>> invert_time(np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.5, 1.5, 3.0]))
    array([0.5, 2.5, nan])
    >>> invert_time(np.array([0.0, 1.0, 2.0 - 4e-16]), np.array([2.0, 2.1])).tolist()
    [2.0, nan]
    """
    h = np.asarray(h, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    out = np.full(t.shape, np.nan)
    tol = 1e-9 * max(1.0, abs(h[0]), abs(h[-1]))
    ok = (t >= h[0] - tol) & (t <= h[-1] + tol)
    tk = np.clip(t[ok], h[0], h[-1])
    k = np.clip(np.searchsorted(h, tk, side="right") - 1, 0, len(h) - 1)
    k1 = np.minimum(k + 1, len(h) - 1)
    step = h[k1] - h[k]
    frac = np.where(step > 0, (tk - h[k]) / np.where(step > 0, step, 1.0), 0.0)
    out[ok] = k + frac
    return out


def hands_take_time(sep: ScenarioSeparation, hands_frame: np.ndarray) -> np.ndarray:
    """Take time (fractional take frame) shown at fractional hands frames, continued at the
    hands' rate into extra material (see the module notes).  NaN stays NaN."""
    g0, g1 = sep.genuine
    h = sep.hands_time[g0:g1 + 1]
    k = np.asarray(hands_frame, dtype=np.float64) - g0
    per = sep.take_fps / sep.hands.fps  # take frames per hands frame at normal speed
    inside = np.interp(k, np.arange(len(h), dtype=np.float64), h)
    out = np.where(k < 0, h[0] + k * per, np.where(k > len(h) - 1, h[-1] + (k - (len(h) - 1)) * per, inside))
    return np.where(np.isfinite(k), out, np.nan)


def alignment_error_s(sep: ScenarioSeparation, hands_frame: np.ndarray) -> np.ndarray:
    """Per body frame, seconds between the instant shown by the body and by the hands frame a
    method chose; NaN where the body frame is not covered or ``hands_frame`` is NaN."""
    hf = np.asarray(hands_frame, dtype=np.float64)
    if hf.shape != sep.truth.shape:
        raise ValueError(f"hands_frame must have shape {sep.truth.shape}, got {hf.shape}")
    err = np.abs(hands_take_time(sep, hf) - sep.body_time) / sep.take_fps
    return np.where(sep.covered, err, np.nan)
