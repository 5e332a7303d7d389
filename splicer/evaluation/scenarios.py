"""Harder ground truth: separated takes that look like real, separate sessions (issue 8).

:func:`splicer.separate.separate` makes the paper's idealised pair: both takes cover the same
performance from first frame to last.  :func:`make_scenario` makes the same kind of pair
(body, hands, truth) with any combination of

* ``extra-begin`` / ``extra-end`` (``extra``: both): 2-8 s of material the body does not
  have before / after the hands' genuine span: a still pose (a take frame from elsewhere,
  held) and unrelated motion (a clip cut from elsewhere in the take, at normal speed);
  before the span: still then motion, after it: motion then still.  The junctions are
  eased over ``blend_s`` seconds inside the extra material (the genuine frames are untouched);
* ``short``: the hands cover only part of the body (a share drawn from ``cover``, 40-80 %, at a
  random place); the truth is NaN for body frames no hands material covers; ``clip`` is the
  same with 3-10 % (a short hand clip on a long body; not among the default :data:`SCENARIOS`);
* ``pause-hands``: the hands performer holds: the hands take stays at one instant of the
  performance for 1-2 s (``K`` hands frames showing the same pose, with the capture noise)
  while the body goes on; the truth jumps by ``K`` hands frames there (steep time map);
* ``pause-body``: the reverse: the body stays at one instant for 1-2 s (``k`` extra body
  frames) while the hands go on; the truth is flat over exactly ``k`` body frames.
  A pause is placed at a moment where the take moves slowly (the wrist speed at most its
  median over the middle 60 % of the covered span), so the other take keeps moving slowly
  there, as when a performer lingers at the end of a gesture;
* ``speed``: local speed of the hands clock 0.33x-3x (instead of 0.5x-2x);
* ``rate``: non-integer rate ratio: the body resampled to 29.97 fps, the hands at 120 fps;
* ``imitation``: a second performance imitates the first: per-gesture arm amplitude changes
  (a factor in ``imitation_amplitude`` per gesture, gestures cut at minima of the wrist
  speed at least 1 s apart), a slow wrist drift (``wrist_drift_deg`` RMS, 3 s smoothness)
  and 1-2 degree arm noise (smoothed over 0.05 s) on the shoulder, upper arm and forearm.

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

Random draws: the warp first (as in :func:`~splicer.separate.separate`), then the structure
(coverage, hands pause, body pause, extra material, in this order, each only when active),
then the capture (:func:`~splicer.separate.confine_capture`), then the imitation.  So with
no component active the hands equal ``separate``'s for the same seed, and the genuine truth
of a scenario equals the base truth of the same seed up to the structural changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks

from ..errors import SplicerError
from ..model.kinematics import global_transforms
from ..model.motion import Motion
from ..rig.roles import Roles, find_roles
from ..model.rotations import quat_hemisphere, quat_mul, quat_normalize, quat_slerp
from .separate import _mean_rotation, confine_capture, finger_joints, warp_time_map
from ..transfer.sampling import resample_motion
from .warps import smooth_noise

__all__ = ["Scenario", "COMPONENTS", "SCENARIOS", "scenario", "ScenarioSeparation", "make_scenario",
           "invert_time", "hands_take_time", "alignment_error_s", "write_scenario"]


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


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _rotvec_quat(v: np.ndarray) -> np.ndarray:
    ang = np.linalg.norm(v, axis=-1, keepdims=True)
    axis = np.where(ang > 0, v / np.where(ang > 0, ang, 1.0), 0.0)
    return np.concatenate([np.cos(ang / 2), np.sin(ang / 2) * axis], axis=-1)


def _ease_junctions(hands: Motion, junctions: list[tuple[int, int, int]]) -> Motion:
    """Ease the poses of frames ``[a, b)`` toward the pose of frame ``anchor`` (weight 1 next
    to the anchor, 0 at the far end), for each ``(a, b, anchor)``; rotations by slerp, the
    root position linearly."""
    if not junctions:
        return hands
    sk = hands.skeleton
    rot3 = [j for j in range(sk.n_joints) if len(sk.rotation_columns(j)) == 3]
    q0 = hands.joint_rotations(rot3)
    q = np.array(q0)
    ch = np.array(hands.channels)
    pos_cols = sk.position_columns(0)
    for a, b, anchor in junctions:
        if b <= a:
            continue
        k = np.arange(a, b)
        dist = np.where(anchor >= b, anchor - k, k - anchor)  # 1 next to the anchor
        w = _smoothstep(1.0 - (dist - 1) / (b - a))  # 1 at the anchor's neighbour, -> 0 far away
        q[k] = quat_slerp(q0[k], np.broadcast_to(q0[anchor], q0[k].shape), np.broadcast_to(w[:, None], q0[k].shape[:2]))
        if pos_cols:
            old = hands.channels[np.ix_(k, pos_cols)]
            ch[np.ix_(k, pos_cols)] = (1 - w[:, None]) * old + w[:, None] * hands.channels[anchor, pos_cols]
    out = hands.with_channels(ch)
    return out.with_rotations(rot3, quat_hemisphere(q, axis=0))


def _imitate(hands: Motion, r: Roles, rng: np.random.Generator, sc: Scenario) -> tuple[Motion, dict]:
    """A second performance: per-gesture arm amplitude, slow wrist drift, arm noise."""
    sk = hands.skeleton
    m, g = hands.n_frames, hands.fps
    q = np.array(hands.rotations)
    changed: set[int] = set()
    drawn: dict = {}
    for side, arm in sorted(r.sides.items()):
        # the shoulder (the upper arm's parent, unless it is the root), the upper arm, the forearm
        chain = [int(sk.parents[arm.upper_arm])] if arm.upper_arm is not None and sk.parents[arm.upper_arm] > 0 else []
        chain += [arm.upper_arm, arm.elbow]
        arm_joints = [j for j in chain if j is not None and len(sk.rotation_columns(j)) == 3]
        # gestures: between minima of the wrist speed at least 1 s apart
        _, p = global_transforms(hands, [arm.wrist])
        speed = np.linalg.norm(np.gradient(p[:, 0], axis=0), axis=-1)
        speed = gaussian_filter1d(speed, 0.1 * g, mode="nearest")
        cuts, _ = find_peaks(-speed, distance=max(int(g), 1))
        bounds = np.concatenate([[0], cuts, [m]])
        factors = rng.uniform(*sc.imitation_amplitude, size=len(bounds) - 1)
        fac = np.empty(m)
        for f, a, b in zip(factors, bounds[:-1], bounds[1:]):
            fac[a:b] = f
        # smooth changes of factor around the cuts (0.3 s)
        fac = gaussian_filter1d(fac, 0.15 * g, mode="nearest")
        if arm_joints:
            mean = _mean_rotation(q[:, arm_joints])
            q[:, arm_joints] = quat_slerp(np.broadcast_to(mean, q[:, arm_joints].shape), q[:, arm_joints],
                                          np.broadcast_to(fac[:, None], (m, len(arm_joints))))
            sd = rng.uniform(*sc.arm_noise_deg)
            nz = smooth_noise(m, rng, sigma=0.05 * g, dims=(len(arm_joints), 3)) * np.radians(sd) / np.sqrt(3.0)
            q[:, arm_joints] = quat_mul(q[:, arm_joints], _rotvec_quat(nz))
            changed.update(arm_joints)
            drawn[f"{side}_arm_noise_deg"] = float(sd)
        if len(sk.rotation_columns(arm.wrist)) == 3:
            dv = smooth_noise(m, rng, sigma=3.0 * g, dims=(3,)) * np.radians(sc.wrist_drift_deg) / np.sqrt(3.0)
            q[:, arm.wrist] = quat_mul(q[:, arm.wrist], _rotvec_quat(dv))
            changed.add(arm.wrist)
        drawn[f"{side}_gesture_factors"] = factors
        drawn[f"{side}_gesture_cuts"] = cuts
    changed_l = sorted(changed)
    out = hands.with_rotations(changed_l, quat_hemisphere(quat_normalize(q[:, changed_l]), axis=0))
    return Motion(sk, out.channels, hands.frame_time, hands.source), drawn


def _wrist_speed(take: Motion, r: Roles) -> np.ndarray:
    """Speed of the faster wrist at each take frame (file units per frame), smoothed over 0.2 s."""
    wrists = [arm.wrist for arm in r.sides.values()]
    _, p = global_transforms(take, wrists)
    v = np.linalg.norm(np.gradient(p, axis=0), axis=-1).max(axis=1)
    return gaussian_filter1d(v, 0.2 * take.fps, mode="nearest")


def _slow_moment(rng: np.random.Generator, speed: np.ndarray, times: np.ndarray, lo: int, hi: int) -> int:
    """A random index into ``times`` (take frames) in the middle 60 % of ``[lo, hi)`` where the
    take moves slowly: the wrist speed at ``times[k]`` is at most the median over that range."""
    a, b = lo + int(0.2 * (hi - lo)), lo + int(0.8 * (hi - lo))
    idx = np.arange(a, max(b, a + 1))
    sp = np.interp(times[idx], np.arange(len(speed), dtype=np.float64), speed)
    slow = idx[sp <= np.median(sp)]
    return int(slow[rng.integers(len(slow))])


def _far_clip_start(rng: np.random.Generator, n: int, length: float, avoid: float, min_gap: float) -> float:
    """Start (take frames) of a clip of ``length`` take frames inside ``[0, n - 1]`` whose
    span stays ``min_gap`` take frames away from the instant ``avoid`` where possible."""
    hi = max(n - 1 - length, 0.0)
    starts = rng.uniform(0.0, hi, size=64)
    far = starts[(starts + length < avoid - min_gap) | (starts > avoid + min_gap)]
    return float(far[0] if len(far) else starts[0])


def make_scenario(take: Motion, sc: Scenario | str, *, rng: np.random.Generator, roles: Roles | None = None,
                  amplitude: tuple[float, float] = (0.25, 0.7), yaw_deg: tuple[float, float] = (25.0, 60.0),
                  noise_deg: float = 0.5, warp_sigma_s: float = 1.5) -> ScenarioSeparation:
    """Separate a full-body take with moving fingers into body, hands and truth under a scenario.

    Parameters
    ----------
    take : Motion
        A full-body take with finger joints, at least 10 s long for extra material and pauses.
    sc : Scenario or str
        The scenario (a name is passed to :func:`scenario`).
    rng : np.random.Generator
        Source of every draw (order in the module notes).
    roles : Roles, optional
    amplitude, yaw_deg, noise_deg, warp_sigma_s
        As in :func:`splicer.separate.separate`.

    Returns
    -------
    ScenarioSeparation
        ``take`` is not modified.
    """
    if isinstance(sc, str):
        sc = scenario(sc)
    if take.n_frames < 2:
        raise ValueError("the take needs at least two frames")
    sk = take.skeleton
    r = roles if roles is not None else find_roles(sk, source=take.source)
    fingers = finger_joints(take, r)
    if not fingers:
        raise ValueError(f"{take.source or 'take'}: no finger joints found; the protocol needs a take with fingers")
    n, fps = take.n_frames, take.fps
    g = float(sc.hands_fps) if sc.hands_fps else 2.0 * fps
    fb = float(sc.body_fps) if sc.body_fps else fps
    per = fps / g  # take frames per hands frame at normal speed
    params: dict = {"hands_fps": g, "body_fps": fb}

    # 1. the genuine hands clock over the whole take (the draw of separate())
    _, h, speed = warp_time_map(n, fps, g, rng, warp_speed=sc.warp_speed, warp_sigma_s=warp_sigma_s)
    params["speed"] = speed

    # 2. the hands cover only part of the take
    if sc.cover is not None:
        c = rng.uniform(*sc.cover)
        start = rng.uniform(0.0, 1.0 - c) if sc.cover_start is None else min(max(float(sc.cover_start), 0.0), 1.0 - c)
        ta, tb = start * (n - 1), (start + c) * (n - 1)
        h = h[(h >= ta) & (h <= tb)]
        params["cover"] = (float(c), float(ta), float(tb))
    if len(h) < 4:
        raise ValueError("the hands' genuine span is too short; use a longer take")

    # 3. the hands performer holds
    if sc.pause_hands_s is not None:
        kh = max(int(round(rng.uniform(*sc.pause_hands_s) * g)), 1)
        q = _slow_moment(rng, _wrist_speed(take, r), h, 0, len(h))
        h = np.concatenate([h[:q + 1], np.full(kh, h[q]), h[q + 1:]])
        params["pause_hands"] = (q, kh)

    # 4. the body clock, and the body holds
    nb = int(np.floor((n - 1) * fb / fps + 1e-9)) + 1
    b = np.arange(nb, dtype=np.float64) * (fps / fb)
    if sc.pause_body_s is not None:
        kb = max(int(round(rng.uniform(*sc.pause_body_s) * fb)), 1)
        inside = np.flatnonzero((b >= h[0]) & (b <= h[-1]))
        p = _slow_moment(rng, _wrist_speed(take, r), b, inside[0], inside[-1] + 1)
        b = np.concatenate([b[:p + 1], np.full(kb, b[p]), b[p + 1:]])
        params["pause_body"] = (p, kb)

    # 5. extra material before and after the genuine span
    pieces_src, pieces_time, junctions = [], [], []
    n_before = n_after = 0
    blend = max(int(round(sc.blend_s * g)), 1)
    if sc.extra_begin_s is not None:
        e = rng.uniform(*sc.extra_begin_s)
        total = max(int(round(e * g)), 2)
        n_still = int(round(rng.uniform(*sc.still_share) * total))
        n_move = total - n_still
        still = rng.uniform(0.0, n - 1)
        start = _far_clip_start(rng, n, n_move * per, h[0], 10.0 * fps)
        src = np.concatenate([np.full(n_still, still), start + np.arange(n_move) * per])
        pieces_src.append(src)
        pieces_time.append(np.full(total, np.nan))
        n_before = total
        params["extra_begin"] = dict(seconds=float(e), still_frames=n_still, still_take_frame=float(still),
                                     move_frames=n_move, move_take_start=float(start))
    pieces_src.append(h)
    pieces_time.append(h)
    if sc.extra_end_s is not None:
        e = rng.uniform(*sc.extra_end_s)
        total = max(int(round(e * g)), 2)
        n_still = int(round(rng.uniform(*(sc.still_share_end or sc.still_share)) * total))
        n_move = total - n_still
        still = rng.uniform(0.0, n - 1)
        start = _far_clip_start(rng, n, n_move * per, h[-1], 10.0 * fps)
        src = np.concatenate([start + np.arange(n_move) * per, np.full(n_still, still)])
        pieces_src.append(src)
        pieces_time.append(np.full(total, np.nan))
        n_after = total
        params["extra_end"] = dict(seconds=float(e), still_frames=n_still, still_take_frame=float(still),
                                   move_frames=n_move, move_take_start=float(start))
    src = np.concatenate(pieces_src)
    hands_time = np.concatenate(pieces_time)
    g0, g1 = n_before, n_before + len(h) - 1
    if n_before:
        eb = params["extra_begin"]
        s, mv = eb["still_frames"], eb["move_frames"]
        if s and mv:  # still -> motion: ease the start of the motion from the still pose
            junctions.append((s, min(s + blend, g0), s - 1))
        junctions.append((max(g0 - blend, s if mv else 0), g0, g0))  # extra -> genuine, inside the extra
    if n_after:
        ee = params["extra_end"]
        mv, s = ee["move_frames"], ee["still_frames"]
        junctions.append((g1 + 1, min(g1 + 1 + blend, g1 + 1 + (mv if mv else s)), g1))
        if s and mv:  # motion -> still: ease the end of the motion into the still pose
            a = g1 + 1 + mv
            junctions.append((max(a - blend, g1 + 1 + blend), a, a))
    params["extra_begin_frames"], params["extra_end_frames"] = n_before, n_after

    # 6. the hands capture
    hands = resample_motion(take, src, 1.0 / g)
    hands = _ease_junctions(hands, junctions)
    hands, cap = confine_capture(hands, take, rng, roles=r, amplitude=amplitude, yaw_deg=yaw_deg,
                                 noise_deg=noise_deg)
    params.update(cap)
    if sc.imitation:
        hands, drawn = _imitate(hands, r, rng, sc)
        params["imitation"] = drawn

    # 7. the body: re-timed when needed, fingers at identity
    if nb == n and sc.pause_body_s is None:
        body = take
    else:
        body = resample_motion(take, b, 1.0 / fb)
    ch = np.array(body.channels)
    for j in fingers:
        ch[:, sk.rotation_columns(j)] = 0.0
    body = Motion(sk, ch, 1.0 / fb, take.source)

    truth = invert_time(h, b)
    truth = np.where(np.isfinite(truth), truth + g0, np.nan)

    # body frames around each pause: from its start to 3 s after its end
    after = int(round(3.0 * fb))
    windows = []
    if "pause_body" in params:
        p, kb = params["pause_body"]
        windows.append((p, min(p + kb + after, len(b) - 1)))
    if "pause_hands" in params:
        q, kh = params["pause_hands"]
        cov = np.flatnonzero(np.isfinite(truth))
        i0 = int(cov[max(np.searchsorted(truth[cov], g0 + q, side="right") - 1, 0)])
        windows.append((i0, min(i0 + after, len(b) - 1)))
    params["pause_windows"] = windows
    params["finger_joints"] = fingers
    return ScenarioSeparation(body, hands, truth, b, hands_time, (g0, g1), fps, sc, params)


def write_scenario(sep: ScenarioSeparation, folder) -> list:
    """Write ``body.bvh``, ``hands.bvh`` and ``truth.csv`` into ``folder`` (created), to try
    ``splice body.bvh hands.bvh`` on a scenario by hand.

    ``truth.csv`` has one row per body frame: ``body_frame``, ``hands_frame`` (fractional, empty
    where uncovered) and ``body_time_s`` (the body frame's instant of the take, seconds).  Files
    made from a licensed take are as restricted as the take: keep them out of the repository.

    Returns
    -------
    list of pathlib.Path
        The three files written.
    """
    from pathlib import Path

    from ..io.bvh import write_bvh

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "body.bvh", out / "hands.bvh", out / "truth.csv"]
    write_bvh(sep.body, files[0])
    write_bvh(sep.hands, files[1])
    rows = ["body_frame,hands_frame,body_time_s"]
    for i, (t, b) in enumerate(zip(sep.truth, sep.body_time)):
        rows.append(f"{i},{'' if not np.isfinite(t) else f'{t:.6f}'},{b / sep.take_fps:.6f}")
    files[2].write_text("\n".join(rows) + "\n", encoding="utf-8")
    return files
