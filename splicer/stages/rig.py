"""Stage 2, rig: roles and up axes of both takes; then the hands take conditioned (dropouts
repaired, a mirror image mirrored back)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace


from ..errors import SplicerError
from ..options import SpliceOptions
from .log import Log
from .load import Inputs

__all__ = ['Rig', 'find_rig', 'Conditioned', 'condition_hands']


# ---------------------------------------------------------------- stage 2: rig

@dataclass(frozen=True)
class Rig:
    """Skeleton roles of both takes, the sides to splice, and how each up axis was decided."""

    body: object  # Roles
    hands: object  # Roles
    sides: tuple[str, ...]
    up: dict = field(default_factory=dict)  # {"body": UpAxis, "hands": UpAxis}


def find_rig(inputs: Inputs, opts: SpliceOptions, log: Log | None = None) -> Rig:
    """Find each take's arms and hands; keep the sides both takes have (others: a warning).

    Raises
    ------
    SplicerError
        No side can be spliced.
    """
    from ..io.limits import check_takes
    from ..rig.roles import FINGERS, SIDES, find_roles
    from ..rig.upaxis import detect_up

    log = log or Log()
    bm, hm, cfg = inputs.body, inputs.hands, inputs.config
    hands_side = opts.hands_side or cfg.hands_side
    # the up axis from the animated motion (head above hips...); the config's up: overrides
    up = {"body": detect_up(bm, override=cfg.up.get("body")), "hands": detect_up(hm, override=cfg.up.get("hands"))}
    for u, src in ((up["body"], bm.source or "body"), (up["hands"], hm.source or "hands")):
        if u.source == "motion" and u.axis != u.rest_axis:
            log.note(f"{src}: the rest skeleton stands along {'xyz'[u.rest_axis]} but the motion along "
                     f"{'xyz'[u.axis]} ({u.why}); using {'xyz'[u.axis]} as up")
    broles = find_roles(bm.skeleton, source=bm.source or "body", mapping=cfg.joints.get("body"), up=up["body"].axis)
    hroles = find_roles(hm.skeleton, source=hm.source or "hands", mapping=cfg.joints.get("hands"),
                        up=up["hands"].axis, side=hands_side)
    todo = []
    for s in (SIDES if opts.side == "both" else (opts.side,)):
        if s not in broles.sides:
            log.note(f"{bm.source or 'body'}: no {s} arm found; the {s} side is skipped")
        elif s not in hroles.sides:
            log.note(f"{hm.source or 'hands'}: no {s} hand found; the {s} side is skipped")
        elif not any(f in hroles.sides[s].fingers for f in FINGERS):
            log.note(f"{hm.source or 'hands'}: the {s} hand has no finger joints; the {s} side is skipped")
        else:
            todo.append(s)
    if not todo:
        raise SplicerError(
            f"no side can be spliced: body sides {sorted(broles.sides) or 'none'}, hands sides "
            f"{sorted(hroles.sides) or 'none'} (requested: {opts.side})")
    check_takes(bm, hm)  # frame counts and durations the splice can handle (splicer.limits)
    log.tick("roles")
    return Rig(broles, hroles, tuple(todo), up)


# ---------------------------------------------------------------- stage 2b: condition the hands take

@dataclass(frozen=True, eq=False)
class Conditioned:
    """The inputs after the hands take was checked and, where needed, converted.

    Attributes
    ----------
    inputs : Inputs
        With the hands motion mirrored (a mirror-image export) when that was decided.
    report : dict
        JSON-ready: ``{"handedness": {...}, "hands_repairs": [...]}``.
    """

    inputs: Inputs
    report: dict


def condition_hands(inputs: Inputs, rig: Rig, opts: SpliceOptions, log: Log | None = None) -> Conditioned:
    """Check the hands take before aligning: dropouts and gaps are repaired (listed in the report),
    and a mirror-image take is mirrored back, each with a warning.

    Raises
    ------
    SplicerError
        The handedness cannot be decided in ``auto`` mode (contradicting geometry).
    """
    from ..rig.handedness import resolve_handedness
    from ..rig.repair import hand_joints, repair_motion, repairs_summary

    log = log or Log()
    hm, repairs = inputs.hands, []
    log.progress("checks: dropouts", 0.0)
    if opts.repair == "on":  # dropouts and gaps of the hand capture, repaired before aligning (and listed)
        hm, repairs = repair_motion(hm, hand_joints(hm.skeleton, [rig.hands.sides[s] for s in rig.sides]),
                                    progress=lambda f: log.progress("checks: dropouts", 0.5 * f))
        if repairs:
            log.note(repairs_summary(repairs, hm.source or "hands"))
    mode = opts.mirror_hands or inputs.config.mirror_hands or "auto"
    log.progress("checks: handedness", 0.5)
    hm, handedness = resolve_handedness(inputs.body, rig.body, hm, rig.hands, rig.sides, mode=mode, note=log.note)
    for m in (inputs.body, inputs.hands, hm):  # the checks' per-joint rotations (all hand joints): not kept
        m.forget_rotations()
    log.tick("checks")
    return Conditioned(replace(inputs, hands=hm),
                       {"handedness": handedness, "hands_repairs": [r.as_dict() for r in repairs]})
