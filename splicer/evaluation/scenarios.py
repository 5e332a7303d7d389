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

Time semantics: :mod:`splicer.evaluation.scenario_types` (with the scenario and result types
and the alignment error); the changes made to the takes: :mod:`splicer.evaluation.scenario_edits`.

Random draws: the warp first (as in :func:`~splicer.separate.separate`), then the structure
(coverage, hands pause, body pause, extra material, in this order, each only when active),
then the capture (:func:`~splicer.separate.confine_capture`), then the imitation.  So with
no component active the hands equal ``separate``'s for the same seed, and the genuine truth
of a scenario equals the base truth of the same seed up to the structural changes.
"""

from __future__ import annotations

import numpy as np

from ..model.motion import Motion
from ..rig.roles import Roles, find_roles
from ..transfer.sampling import resample_motion
# the scenario and result types and the helpers, re-exported: they were defined here before the split
from .scenario_edits import _ease_junctions, _far_clip_start, _imitate, _slow_moment, _wrist_speed  # noqa: F401
from .scenario_types import (ALL, COMPONENTS, SCENARIOS, Scenario, ScenarioSeparation, alignment_error_s,  # noqa: F401
                             hands_take_time, invert_time, scenario)
from .separate import confine_capture, finger_joints, warp_time_map

__all__ = ["Scenario", "COMPONENTS", "SCENARIOS", "scenario", "ScenarioSeparation", "make_scenario",
           "invert_time", "hands_take_time", "alignment_error_s", "write_scenario"]


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
