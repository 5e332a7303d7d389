"""A procedural speaker with fingers, for tests and examples without capture files.

:func:`gesture_skeleton` is an adult (about 1.75 m) rest skeleton with Mixamo joint names, in
centimetres, Y up, facing +Z, arms in T-pose with the palms down (the character's left is
+X).  Every joint but the root has channels ``Zrotation Xrotation Yrotation``; the root
(``Hips``) has ``Xposition Yposition Zposition Zrotation Xrotation Yrotation``.

:func:`make_gesture_take` animates it as a speaker: each arm runs its own sequence of
gestures, each with preparation, stroke, hold and retraction phases between rests —
beats, pointing, counting on the fingers, open-palm presentation and pinching — with random
timing and amplitude.  Joint angles are interpolated between key poses with monotone cubic
(PCHIP) curves, so they are C1 and have true holds; small smooth noise keeps holds alive.
The torso sways, the head nods, the hips shift weight and the body slowly turns.  Finger
flexion stays within 0-90 degrees at the MCP and PIP joints, abduction within 15 degrees.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator

from ..model.motion import Motion, Skeleton
from ..model.rotations import euler_channels_deg, quat_between, quat_mul
from .warps import smooth_noise

__all__ = ["gesture_skeleton", "make_gesture_take", "FINGER_NAMES"]

FINGER_NAMES = ("Thumb", "Index", "Middle", "Ring", "Pinky")
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
_JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")

# left-hand finger geometry (cm, hand frame in T-pose: fingers +X, palm -Y, thumb +Z)
_THUMB_DIR = np.array([1.0, -0.35, 0.9]) / np.linalg.norm([1.0, -0.35, 0.9])
_FINGER_GEOMETRY = {
    #          base offset from the wrist   segment lengths (prox, mid, dist) + tip
    "Thumb": ((2.2, -1.5, 3.0), (4.0, 3.2, 2.6)),
    "Index": ((9.4, 0.2, 2.4), (4.3, 2.5, 2.2)),
    "Middle": ((9.7, 0.3, 0.6), (4.7, 2.9, 2.4)),
    "Ring": ((9.2, 0.1, -1.2), (4.3, 2.7, 2.3)),
    "Pinky": ((8.4, -0.3, -2.8), (3.4, 2.1, 2.0)),
}


def gesture_skeleton() -> Skeleton:
    """The rest skeleton of :func:`make_gesture_take` (65 joints, cm, Y up, facing +Z, T-pose)."""
    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, float, float]] = []
    ends: list[tuple[float, float, float] | None] = []

    def add(name, parent, offset, end=None):
        names.append(name)
        parents.append(parent)
        offsets.append(tuple(float(v) for v in offset))
        ends.append(end)
        return len(names) - 1

    hips = add("Hips", -1, (0.0, 98.0, 0.0))
    spine = add("Spine", hips, (0.0, 8.5, -1.0))
    spine1 = add("Spine1", spine, (0.0, 10.5, 0.0))
    spine2 = add("Spine2", spine1, (0.0, 12.0, 0.5))
    neck = add("Neck", spine2, (0.0, 18.0, -0.5))
    add("Head", neck, (0.0, 9.0, 1.0), end=(0.0, 18.0, 0.0))
    for side, sx in (("Left", 1.0), ("Right", -1.0)):
        sh = add(f"{side}Shoulder", spine2, (sx * 3.0, 13.0, -0.5))
        arm = add(f"{side}Arm", sh, (sx * 12.5, 0.0, 0.0))
        fore = add(f"{side}ForeArm", arm, (sx * 28.5, 0.0, 0.0))
        hand = add(f"{side}Hand", fore, (sx * 25.5, 0.0, 0.0))
        for finger in FINGER_NAMES:
            base, lengths = _FINGER_GEOMETRY[finger]
            d = _THUMB_DIR if finger == "Thumb" else np.array([1.0, 0.0, 0.0])
            mirror = np.array([sx, 1.0, 1.0])
            p = add(f"{side}Hand{finger}1", hand, np.array(base) * mirror)
            p = add(f"{side}Hand{finger}2", p, lengths[0] * d * mirror)
            add(f"{side}Hand{finger}3", p, lengths[1] * d * mirror, end=tuple(lengths[2] * d * mirror))
    for side, sx in (("Left", 1.0), ("Right", -1.0)):
        up = add(f"{side}UpLeg", hips, (sx * 9.5, -6.0, 0.0))
        leg = add(f"{side}Leg", up, (0.0, -43.5, 0.0))
        foot = add(f"{side}Foot", leg, (0.0, -42.0, -0.5))
        add(f"{side}ToeBase", foot, (0.0, -6.5, 13.0), end=(0.0, 0.0, 5.0))
    channels = [_ROOT_CHANNELS if p < 0 else _JOINT_CHANNELS for p in parents]
    es = np.array([e if e is not None else (np.nan,) * 3 for e in ends], dtype=np.float64)
    return Skeleton(tuple(names), np.array(parents), np.array(offsets), tuple(channels), es)


# --- rotations from anatomical angles (left side; the right side is mirrored) -------------

def _axis_angle(axis, deg) -> np.ndarray:
    """Quaternions of rotations by ``deg`` (T,) degrees about the fixed ``axis`` (3,)."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    h = np.radians(np.asarray(deg, dtype=np.float64)) / 2
    return np.concatenate([np.cos(h)[..., None], np.sin(h)[..., None] * axis], axis=-1)


def _mirror(q: np.ndarray) -> np.ndarray:
    """The rotation reflected through the plane x = 0 (left side -> right side)."""
    return q * np.array([1.0, 1.0, -1.0, -1.0])


# arm pose parameters (degrees, or 0..1 for finger curls and spread)
_P = ("clav", "elev", "az", "twist", "elbow", "sup", "wflex", "wdev",
      "thumb", "index", "middle", "ring", "pinky", "spread")
_IX = {k: i for i, k in enumerate(_P)}
_ARM_PARAMS = slice(0, 8)   # scaled by a gesture's amplitude
_REST = dict(clav=0.0, elev=8.0, az=15.0, twist=5.0, elbow=72.0, sup=5.0, wflex=8.0, wdev=0.0,
             thumb=0.25, index=0.3, middle=0.36, ring=0.42, pinky=0.48, spread=0.15)


def _pose(**kw) -> np.ndarray:
    p = dict(_REST)
    p.update(kw)
    return np.array([p[k] for k in _P], dtype=np.float64)


class _Timeline:
    """Key poses of one arm: (time in seconds, parameter vector)."""

    def __init__(self, rest: np.ndarray):
        self.t: list[float] = [0.0]
        self.p: list[np.ndarray] = [rest]
        self.rest = rest

    @property
    def now(self) -> float:
        return self.t[-1]

    def key(self, dt: float, pose: np.ndarray) -> None:
        self.t.append(self.now + max(float(dt), 0.06))
        self.p.append(np.asarray(pose, dtype=np.float64))

    def hold(self, dt: float) -> None:
        self.key(dt, self.p[-1])


def _scaled(rest: np.ndarray, target: np.ndarray, amp: float) -> np.ndarray:
    out = np.array(target)
    out[_ARM_PARAMS] = rest[_ARM_PARAMS] + amp * (target[_ARM_PARAMS] - rest[_ARM_PARAMS])
    return out


def _gesture(tl: _Timeline, kind: str, rng: np.random.Generator, amp: float, tempo: float) -> None:
    """Append one gesture (preparation, stroke(s), hold, retraction) to the timeline."""
    u = rng.uniform
    rest = tl.rest
    S = lambda pose: _scaled(rest, pose, amp)  # noqa: E731
    if kind == "beat":
        top = _pose(elev=u(12, 25), az=u(25, 50), elbow=u(90, 110), sup=u(20, 50), wflex=u(-10, 5),
                    thumb=0.2, index=u(0.1, 0.3), middle=u(0.15, 0.35), ring=0.35, pinky=0.4, spread=u(0.2, 0.5))
        tl.key(u(0.35, 0.6) * tempo, S(top))                              # preparation
        for _ in range(rng.integers(2, 5)):
            down = top.copy()
            down[_IX["elbow"]] -= u(15, 30)
            down[_IX["elev"]] -= u(3, 8)
            down[_IX["wflex"]] += u(10, 25)
            down[[_IX["index"], _IX["middle"]]] += u(0.0, 0.15)
            tl.key(u(0.14, 0.24) * tempo, S(down))                          # stroke
            tl.hold(u(0.03, 0.12) * tempo)                                  # post-stroke hold
            tl.key(u(0.22, 0.4) * tempo, S(top))                            # recoil
    elif kind == "point":
        aim = _pose(elev=u(35, 65), az=u(50, 90), twist=u(-10, 10), elbow=u(20, 45), sup=u(-40, -10),
                    wflex=u(-15, 0), wdev=u(-5, 10), thumb=u(0.5, 0.7), index=u(0.0, 0.08),
                    middle=u(0.8, 0.95), ring=u(0.85, 1.0), pinky=u(0.85, 1.0), spread=0.05)
        tl.key(u(0.45, 0.7) * tempo, S(aim))                                # preparation
        push = aim.copy()
        push[_IX["elbow"]] -= u(10, 18)
        push[_IX["elev"]] += u(3, 8)
        tl.key(u(0.15, 0.25) * tempo, S(push))                              # stroke
        tl.hold(u(0.4, 1.0) * tempo)                                        # hold
    elif kind == "count":
        n = int(rng.integers(2, 6))
        fist = _pose(elev=u(15, 30), az=u(40, 70), twist=u(10, 25), elbow=u(100, 125), sup=u(40, 75),
                     wflex=u(-20, -5), thumb=u(0.75, 0.9), index=u(0.85, 0.95), middle=u(0.85, 0.95),
                     ring=u(0.88, 1.0), pinky=u(0.88, 1.0), spread=0.05)
        tl.key(u(0.45, 0.7) * tempo, S(fist))                               # preparation
        tl.hold(u(0.1, 0.3) * tempo)
        pose = fist.copy()
        for finger in ("index", "middle", "ring", "pinky", "thumb")[:n]:
            pose = pose.copy()
            pose[_IX[finger]] = u(0.0, 0.1)
            pose[_IX["spread"]] = min(pose[_IX["spread"]] + 0.15, 0.8)
            pose[_IX["elbow"]] += u(-6, 6)
            pose[_IX["wflex"]] += u(-4, 4)
            tl.key(u(0.16, 0.26) * tempo, S(pose))                          # stroke: extend one finger
            tl.hold(u(0.25, 0.55) * tempo)                                  # hold
    elif kind == "present":
        open_ = _pose(elev=u(18, 35), az=u(25, 60), twist=u(-25, -5), elbow=u(70, 95), sup=u(70, 95),
                      wflex=u(-20, -5), wdev=u(-5, 5), thumb=u(0.05, 0.15), index=u(0.0, 0.12),
                      middle=u(0.02, 0.15), ring=u(0.05, 0.18), pinky=u(0.05, 0.2), spread=u(0.5, 0.8))
        tl.key(u(0.4, 0.65) * tempo, S(open_))                              # preparation
        wide = open_.copy()
        wide[_IX["az"]] -= u(10, 25)
        wide[_IX["twist"]] -= u(10, 20)
        tl.key(u(0.25, 0.4) * tempo, S(wide))                               # stroke: open outward
        tl.hold(u(0.5, 1.2) * tempo)                                        # hold
    elif kind == "pinch":
        pinch = _pose(elev=u(12, 25), az=u(40, 65), twist=u(5, 20), elbow=u(95, 115), sup=u(20, 45),
                      wflex=u(-5, 10), thumb=u(0.5, 0.6), index=u(0.45, 0.6), middle=u(0.55, 0.7),
                      ring=u(0.65, 0.8), pinky=u(0.7, 0.85), spread=0.05)
        tl.key(u(0.4, 0.6) * tempo, S(pinch))
        for _ in range(rng.integers(1, 4)):
            down = pinch.copy()
            down[_IX["elbow"]] -= u(8, 16)
            down[_IX["wflex"]] += u(8, 15)
            tl.key(u(0.15, 0.25) * tempo, S(down))
            tl.key(u(0.2, 0.35) * tempo, S(pinch))
        tl.hold(u(0.2, 0.5) * tempo)
    else:  # pragma: no cover - internal
        raise ValueError(kind)
    # retraction: back to a (slightly varied) rest
    back = rest.copy()
    back[_ARM_PARAMS] += rng.normal(0.0, 2.0, 8)
    tl.key(u(0.45, 0.8) * tempo, back)


_KINDS = ("beat", "point", "count", "present", "pinch")


def _arm_timeline(seconds: float, rng: np.random.Generator, *, dominant: bool) -> _Timeline:
    tl = _Timeline(_pose())
    tl.hold(rng.uniform(0.1, 0.6))
    weights = np.array([0.3, 0.17, 0.18, 0.2, 0.15]) if dominant else np.array([0.35, 0.1, 0.1, 0.3, 0.15])
    while tl.now < seconds:
        kind = str(rng.choice(_KINDS, p=weights / weights.sum()))
        _gesture(tl, kind, rng, amp=rng.uniform(0.6, 1.2), tempo=rng.uniform(0.75, 1.35))
        rest_mean = 0.5 if dominant else 1.4
        tl.hold(rng.exponential(rest_mean) + 0.1)                          # rest
    return tl


def _arm_rotations(params: np.ndarray) -> dict[str, np.ndarray]:
    """Local rotations (T, 4) of one LEFT arm's joints from pose parameters (T, P)."""
    P = {k: params[:, i] for i, k in enumerate(_P)}
    T = params.shape[0]
    X, Y, Z = np.eye(3)
    out: dict[str, np.ndarray] = {}
    # clavicle: elevation about the forward axis (+X toward +Y)
    out["Shoulder"] = _axis_angle(Z, P["clav"])
    # upper arm: swing +X onto the direction (elevation from down, azimuth from the side
    # toward the front), then humeral twist about its own axis (positive = internal)
    e, a = np.radians(P["elev"]), np.radians(P["az"])
    u = np.stack([np.sin(e) * np.cos(a), -np.cos(e), np.sin(e) * np.sin(a)], axis=-1)
    swing = quat_between(np.broadcast_to(X, (T, 3)), u)
    out["Arm"] = quat_mul(swing, _axis_angle(X, P["twist"]))
    # elbow flexion brings the forearm toward the front of the upper arm
    out["ForeArm"] = _axis_angle(-Y, P["elbow"])
    # wrist: supination (about the hand axis, thumb turns up in T-pose), flexion toward the palm, radial deviation
    out["Hand"] = quat_mul(quat_mul(_axis_angle(-X, P["sup"]), _axis_angle(-Z, P["wflex"])), _axis_angle(-Y, P["wdev"]))
    # fingers: flexion toward the palm (about -Z), abduction in the palm plane (about -Y)
    spread = P["spread"]
    abd = {"Index": 10.0, "Middle": 2.0, "Ring": -7.0, "Pinky": -14.0}
    for finger, limits in (("Index", (85.0, 90.0, 65.0)), ("Middle", (88.0, 90.0, 68.0)),
                           ("Ring", (88.0, 90.0, 65.0)), ("Pinky", (90.0, 90.0, 65.0))):
        c = np.clip(P[finger.lower()], 0.0, 1.0)
        mcp = quat_mul(_axis_angle(-Y, abd[finger] * spread * (1.0 - 0.6 * c)), _axis_angle(-Z, limits[0] * c))
        out[f"{finger}1"] = mcp
        out[f"{finger}2"] = _axis_angle(-Z, limits[1] * c ** 1.2)
        out[f"{finger}3"] = _axis_angle(-Z, limits[2] * c ** 1.4)
    # thumb: flexion across the palm (toward the palm and the little finger), abduction away from the index
    c = np.clip(P["thumb"], 0.0, 1.0)
    across = np.array([0.0, -1.0, -0.8])
    k = np.cross(_THUMB_DIR, across / np.linalg.norm(across))
    out["Thumb1"] = quat_mul(_axis_angle(-Y, 15.0 * spread), _axis_angle(k, 35.0 * c))
    out["Thumb2"] = _axis_angle(k, 45.0 * c)
    out["Thumb3"] = _axis_angle(k, 70.0 * c ** 1.3)
    return out


def _curves(tl: _Timeline, t: np.ndarray) -> np.ndarray:
    times = np.array(tl.t)
    keys = np.stack(tl.p)
    return PchipInterpolator(times, keys, axis=0, extrapolate=False)(np.clip(t, times[0], times[-1]))


def _channels_from_rotations(sk: Skeleton, q: np.ndarray, root_pos: np.ndarray) -> np.ndarray:
    T = q.shape[0]
    ch = np.zeros((T, sk.n_channels))
    for j in range(sk.n_joints):
        cols = sk.rotation_columns(j)
        ch[:, cols] = euler_channels_deg(q[:, j], sk.rotation_order(j))
    ch[:, sk.position_columns(0)] = root_pos
    return ch


def make_gesture_take(seconds: float, fps: float, rng: np.random.Generator) -> Motion:
    """A speaker gesturing with both arms and all fingers.

    Parameters
    ----------
    seconds : float
        Duration from the first to the last frame, seconds (> 0).
    fps : float
        Frames per second (> 0).
    rng : np.random.Generator
        Source of every random choice; the same seed gives the same take.

    Returns
    -------
    Motion
        ``round(seconds * fps) + 1`` frames on :func:`gesture_skeleton`, source ``"synth:gesture"``.
        The right arm is dominant (gestures more, with more pointing and counting); the left
        arm gestures less and rests longer.
    """
    if not (seconds > 0 and fps > 0):
        raise ValueError(f"seconds and fps must be positive, got {seconds}, {fps}")
    sk = gesture_skeleton()
    T = int(round(seconds * fps)) + 1
    t = np.arange(T) / fps
    J = sk.n_joints
    q = np.zeros((T, J, 4))
    q[..., 0] = 1.0
    idx = {n: i for i, n in enumerate(sk.names)}
    X, Y, Z = np.eye(3)

    def noise(sigma_s: float, dims=()):
        return smooth_noise(T, rng, sigma=max(sigma_s * fps, 0.5), dims=dims)

    # arms and hands
    for side, dominant in (("Right", True), ("Left", False)):
        tl = _arm_timeline(seconds, rng, dominant=dominant)
        params = _curves(tl, t)
        jitter = noise(0.35, dims=(len(_P),))
        params[:, :8] += jitter[:, :8] * np.array([0.5, 1.5, 2.0, 2.0, 2.5, 3.0, 2.0, 1.5])
        params[:, 8:13] += 0.03 * jitter[:, 8:13]
        params[:, 8:] = np.clip(params[:, 8:], 0.0, 1.0)
        for name, qq in _arm_rotations(params).items():
            j = idx[side + (f"Hand{name}" if name[-1].isdigit() else name)]
            q[:, j] = qq if side == "Left" else _mirror(qq)

    # torso sway, head nods
    sway = noise(1.2, dims=(3,))
    for name, w in (("Spine", 0.45), ("Spine1", 0.35), ("Spine2", 0.25)):
        q[:, idx[name]] = quat_mul(quat_mul(_axis_angle(Y, 4.0 * w * sway[:, 0]), _axis_angle(X, 2.0 + 3.0 * w * sway[:, 1])),
                                   _axis_angle(Z, 3.0 * w * sway[:, 2]))
    nod = noise(0.5, dims=(3,))
    q[:, idx["Neck"]] = quat_mul(_axis_angle(Y, 6.0 * nod[:, 0]), _axis_angle(X, -2.0 + 2.0 * nod[:, 1]))
    q[:, idx["Head"]] = quat_mul(_axis_angle(X, 4.0 * nod[:, 1]), _axis_angle(Z, 3.0 * nod[:, 2]))

    # root: weight shift (lateral, slow), small bob, slow turn; legs keep the feet roughly planted
    period = rng.uniform(4.0, 8.0)
    phase = rng.uniform(0, 2 * np.pi)
    drift = noise(2.0, dims=(3,))
    shift = 3.5 * np.sin(2 * np.pi * t / period + phase) + 1.5 * drift[:, 0]
    root_pos = np.stack([shift, 98.0 - 0.6 * np.abs(np.sin(2 * np.pi * t / period + phase)) + 0.3 * drift[:, 1],
                         1.5 * drift[:, 2]], axis=-1)
    turn = rng.uniform(-1, 1) * 25.0 * np.clip(t / max(seconds, 1e-9), 0, 1) + 6.0 * noise(2.5)
    q[:, idx["Hips"]] = quat_mul(_axis_angle(Y, turn), _axis_angle(Z, -0.8 * shift))
    tilt = np.degrees(np.arctan2(shift, 85.0))
    for side in ("Left", "Right"):
        q[:, idx[f"{side}UpLeg"]] = quat_mul(_axis_angle(Z, 0.8 * shift - tilt), _axis_angle(Y, -0.7 * turn))
        q[:, idx[f"{side}Foot"]] = _axis_angle(Z, tilt)
    return Motion(sk, _channels_from_rotations(sk, q, root_pos), 1.0 / fps, "synth:gesture")
