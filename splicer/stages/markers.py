"""Stage 3, markers: the virtual (or optical) markers of one side in both takes."""

from __future__ import annotations

from dataclasses import dataclass, field


from ..align.frames import FrameSpaces, pins_from_config
from .rig import Rig
from .log import Log
from .load import Inputs

__all__ = ['SideMarkers', 'side_markers', 'to_common']


# ---------------------------------------------------------------- stage 3: markers

@dataclass(frozen=True, eq=False)
class SideMarkers:
    """One side's markers at the common (body) rate, and its pins.

    Attributes
    ----------
    side : str
    body, hands : Markers
        Body markers (``n`` frames) and hands markers resampled to the body rate (``m`` frames).
    spaces : FrameSpaces
    pins : tuple of Pin
        The user's pins for this side, in file frames.
    real : dict
        ``"body"``/``"hands"`` -> the optical markers' report, for a take aligned on real markers.
    hand_only : bool
        The hands file is hand-only on this side (no shoulder: the body's markers are measured
        from its root, :func:`splicer.rig.handonly.hand_only_view`).
    placed : tuple of str
        How the body's and the hands' markers were placed (:func:`splicer.rig.markers.marker_placement`;
        ``"optical"`` for real markers): the wrist's refinement runs only where they are equal.
    noise : dict
        ``"body"``/``"hands"`` -> a draw of the optical markers' white noise, ``p1..p4`` shaped and
        timed as :attr:`body` / :attr:`hands` (:meth:`splicer.rig.marker_arm.MarkerArm.noise_sample`,
        carried through the same resampling), for a take aligned on real markers whose noise is known.
    """

    side: str
    body: object
    hands: object
    spaces: FrameSpaces
    pins: tuple
    real: dict = field(default_factory=dict)  # issue 14: "body"/"hands" -> optical marker report
    hand_only: bool = False
    placed: tuple = ("", "")
    noise: dict = field(default_factory=dict)


def _align_up(markers, up_to: int):
    """Relabel axes cyclically (a proper rotation) so the vertical axis becomes ``up_to``."""
    from ..rig.markers import Markers

    if markers.up == up_to:
        return markers
    shift = (up_to - markers.up) % 3
    perm = [(k - shift) % 3 for k in range(3)]  # new axis k takes old axis perm[k]
    return Markers(markers.points[..., perm], markers.shoulder[..., perm], markers.heading,
                   up_to, markers.fps, markers.side)


def to_common(markers, up: int, fps: float | None = None):
    """Markers as the alignment sees them: axes relabelled so that ``up`` is vertical, and
    resampled to ``fps`` (the body's rate: the hands take's markers) when given.

    The one path a take's markers take, and the draw of their noise with them
    (:meth:`splicer.rig.marker_arm.MarkerArm.noise_sample`): every step is linear, so a draw
    carried this way is the noise as the alignment sees it.
    """
    from ..align.passes import resample_markers

    m = _align_up(markers, up)
    return m if fps is None else resample_markers(m, fps)


def side_markers(inputs: Inputs, rig: Rig, side: str, log: Log | None = None) -> SideMarkers:
    """Virtual markers of ``side`` in both takes, the hands brought to the body's rate and up axis."""
    from ..rig.handonly import coincident_forearm, hand_only_view, is_hand_only
    from ..rig.markers import arm_markers, marker_placement

    log = log or Log()
    log.progress(f"{side}: markers", 0.0)
    bm, hm = inputs.body, inputs.hands
    bmk = arm_markers(bm, rig.body.sides[side], rig.body.up)
    log.progress(f"{side}: markers", bm.n_frames / (bm.n_frames + hm.n_frames))  # the bar by frames: body, then hands
    harm = rig.hands.sides[side]
    hand_only = is_hand_only(harm)
    body_placed = marker_placement(bm.skeleton, rig.body.sides[side])
    if hand_only and not is_hand_only(rig.body.sides[side]):
        # a hand-only file has no shoulder nor elbow: the body's markers are made the same way
        # (from its root, with the same virtual forearm)
        forearm = coincident_forearm(hm.skeleton, harm) is not None
        bmk = hand_only_view(bm, rig.body.sides[side], bmk, forearm_joint=forearm)
        if not forearm:  # the body's p3 now on a virtual forearm turned with its wrist (with one, it keeps its real p3)
            body_placed = marker_placement(bm.skeleton, rig.body.sides[side], p3="hand")
    hmk = _align_up(arm_markers(hm, rig.hands.sides[side], rig.hands.up), rig.body.up)
    log.progress(f"{side}: markers", 1.0)
    # --- issue 14: real optical markers replace the virtual ones of the take that has them ---
    real, noise = {}, {}
    for take, traj, motion in (("body", inputs.body_markers, bm), ("hands", inputs.hands_markers, hm)):
        if traj is None:
            continue
        from ..rig.marker_arm import arm_from_trajectories, on_frames

        arm = arm_from_trajectories(traj, side, mapping=inputs.config.markers.get(take))
        if not arm.roles.sided and len(rig.sides) > 1 and inputs.config.hands_side != side:
            log.note(f"{traj.source}: the marker names tell no side; not used for the {side} side (name the side "
                     f"with hands_side: or under markers: in the constraints file)")
            continue
        mk, notes = on_frames(arm.markers, motion.n_frames, motion.fps, what=f"{traj.source} ({side} side)")
        for msg in arm.notes + notes:
            log.note(msg)
        real[take] = arm.report(traj)
        drawn = arm.noise_sample()
        if drawn is not None:  # put on the take's frames as the markers are; the rest below (to_common)
            noise[take] = on_frames(drawn, motion.n_frames, motion.fps)[0]
        if take == "body":
            bmk = _align_up(mk, rig.body.up)
        else:
            hmk = _align_up(mk, rig.body.up)
    hands_placed = marker_placement(hm.skeleton, harm)
    if len(real) == 1 and not hand_only and next(iter(real.values()))["derivation"] == "role averages":
        # optical markers on one take only: the other take's virtual wrist markers sit where real ones
        # do, on the styloids (turned with the forearm and its pronation, not with the hand's bending),
        # so that both takes' markers read the same motion (benchmarks/HISTORY.md, 0.21.0).  Markers
        # derived from rigid segments carry their wrist markers with the hand, as the palm placement does
        if "hands" in real:
            bmk = arm_markers(bm, rig.body.sides[side], rig.body.up, wrist="styloid")
            body_placed = marker_placement(bm.skeleton, rig.body.sides[side], wrist="styloid")
        else:
            hmk = _align_up(arm_markers(hm, harm, rig.hands.up, wrist="styloid"), rig.body.up)
            hands_placed = marker_placement(hm.skeleton, harm, wrist="styloid")
    # --- end issue 14 ---
    pins = pins_from_config(inputs.config, side, inputs.spaces)
    placed = ("optical" if "body" in real else body_placed, "optical" if "hands" in real else hands_placed)
    noise = {t: to_common(m, rig.body.up, None if t == "body" else bm.fps).points for t, m in noise.items()}
    out = SideMarkers(side, bmk, to_common(hmk, rig.body.up, bm.fps), inputs.spaces, pins, real, hand_only, placed, noise)
    if side == rig.sides[-1]:  # the arm chains' rotations (the sides share the root and spine): not needed again
        bm.forget_rotations()
        hm.forget_rotations()
    log.tick("markers")
    return out
