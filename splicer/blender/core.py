"""The add-on's logic as plain functions (need ``bpy``, no UI): usable from Blender's Python
console, scripts and tests run with the ``bpy`` module in the background.

Frames.  A take's **file frame** ``k`` (0-based, what splicer and the constraints file use)
is the scene frame ``first + k * step``: ``first`` the first key of the armature's action
(an importer keys frame 0 of the file at the scene's start frame), ``step`` 1 for a take at
the scene's rate (0.5 for a 60 fps take scaled into a 30 fps scene).

Pins from timeline markers.  A marker named ``pin:<hands scene frame>`` placed at a body
scene frame pins that body frame to the hands frame shown at that scene frame: the animator scrubs the hands
armature to a clear event (a clap, a tap), reads the frame number, scrubs the body to the
same event and adds a marker there named ``pin:<that number>`` (M, then F2 to rename).
The number may have a fraction (``pin:174.5``: a 60 fps take in a 30 fps scene
shows its odd frames between scene frames).  Optional: a side, ``pin:L:<n>`` /
``pin:R:<n>`` (default both sides), and a tolerance in
hands frames, ``pin:<n>~<T>`` (default 2).  Other markers are ignored; a marker named
``pin:`` with something unreadable is an error naming it.

The result.  The fingers are baked onto the body armature as a **new action**
``<body>_spliced`` (the original action is untouched and stays in the file).  The same
action animates custom properties ``splicer_timemap_<side>`` of the body object: the hands
file frame shown at each body frame, one key per body frame (edit them in the Graph
Editor); :func:`reapply_time_map` re-samples the fingers at the edited map without
re-solving.  Low-confidence and uncovered ranges become timeline markers
``splicer:<side> low <a>-<b>`` / ``splicer:<side> uncovered <a>-<b>`` at their first frame
(scene frames), and the report summary is stored as JSON in the scene property
``splicer_report``.
"""

from __future__ import annotations

import importlib
import json
import re

import numpy as np

__all__ = ["package", "first_frame", "take_step", "mark_ranges", "armature_motion", "markers_to_pins",
           "splice_armatures", "time_map_to_fcurve", "fcurve_to_time_map", "reapply_time_map", "report_summary",
           "PIN_RE", "TIMEMAP_PROP"]

PIN_RE = re.compile(r"^pin:(?:(?P<side>[LRlr]):)?(?P<hands>-?\d+(?:\.\d+)?)(?:~(?P<tol>\d+))?$")
TIMEMAP_PROP = "splicer_timemap_{side}"
RESULT_PROP = "splicer_result"  # on the body object: JSON of what reapply needs (hands object, options, pins)
_RANGE_PREFIX = "splicer:"


def package():
    """splicer itself: the copy bundled in the built extension, else the package around this one."""
    here = __package__ or "splicer.blender"
    try:
        return importlib.import_module(here + ".splicer")
    except ImportError:
        return importlib.import_module(here.rsplit(".", 1)[0])


def _sub(name: str):
    return importlib.import_module(package().__name__ + "." + name)


def first_frame(obj) -> float:
    """Scene frame of the take's file frame 0: its action's first frame (the scene start without one)."""
    import bpy

    ad = obj.animation_data
    if ad is not None and ad.action is not None:
        t = _sub("io.fbx")._key_times(ad.action)
        return float(t[0]) if len(t) else float(ad.action.frame_range[0])
    return float(bpy.context.scene.frame_start)


def take_step(obj) -> float:
    """Scene frames per file frame of the take on ``obj`` (1.0, or e.g. 0.5 for a 60 fps BVH
    imported into a 30 fps scene with "scale FPS"): the median spacing of its bone keys."""
    fbx = _sub("io.fbx")
    ad = obj.animation_data
    t = fbx._key_times(ad.action) if ad is not None and ad.action is not None else np.zeros(0)
    return float(np.median(np.diff(t))) if len(t) > 1 else 1.0


def armature_motion(obj, action=None):
    """An armature's animation as a Motion (:func:`splicer.io.fbx.armature_motion`), sampling
    ``action`` (default the active one) over its frame range."""
    fbx = _sub("io.fbx")
    if action is not None and obj.animation_data is not None and obj.animation_data.action is not action:
        keep = obj.animation_data.action
        obj.animation_data.action = action
        try:
            return fbx.armature_motion(obj)
        finally:
            obj.animation_data.action = keep
    return fbx.armature_motion(obj)


def markers_to_pins(markers, body_first: float, hands_first: float, *, tolerance: int = 2, body_step: float = 1.0,
                    hands_step: float = 1.0):
    """Timeline markers named ``pin:...`` as a SpliceConfig's pairs (file frames), sorted by body frame.

    Parameters
    ----------
    markers : iterable of objects with ``.name`` and ``.frame``
        E.g. ``scene.timeline_markers``.
    body_first, hands_first : float
        Scene frames of each take's file frame 0 (:func:`first_frame`).
    body_step, hands_step : float
        Scene frames per file frame of each take (:func:`take_step`); a pin's scene frames
        are converted to file frames, rounded.

    Returns
    -------
    SpliceConfig
        ``source`` names the markers, so a bad pin's message says "timeline marker 'pin:347'".

    Raises
    ------
    ConstraintError
        A ``pin:`` marker whose name cannot be read.
    """
    constraints = _sub("io.config")
    errors = _sub("errors")
    found = []
    for mk in markers:
        name = mk.name.strip()
        if not name.lower().startswith("pin:"):
            continue
        m = PIN_RE.match(name)
        if m is None:
            raise errors.ConstraintError(
                f"timeline marker {mk.name!r} at frame {mk.frame}: a pin is named pin:<hands frame>, "
                "pin:L:<hands frame> or pin:<hands frame>~<tolerance>")
        side = {"l": "left", "r": "right", None: "both"}[m["side"].lower() if m["side"] else None]
        body = int(round((mk.frame - body_first) / body_step))
        found.append((body, int(round((float(m["hands"]) - hands_first) / hands_step)),
                      None if m["tol"] is None else int(m["tol"]), side, mk.name))
    found.sort()
    pairs = tuple(constraints.PairSpec(b, h, t, s, k + 1, k) for k, (b, h, t, s, _) in enumerate(found))
    return constraints.SpliceConfig(pairs=pairs, tolerance=tolerance, source="timeline markers")


def _object_config(body_obj, hands_obj, scene):
    return markers_to_pins(scene.timeline_markers, first_frame(body_obj), first_frame(hands_obj),
                           body_step=take_step(body_obj), hands_step=take_step(hands_obj))


def time_map_to_fcurve(obj, action, side: str, time_map: np.ndarray, first: int):
    """Key the time map (hands file frame per body frame; NaN = uncovered, not keyed) as the
    custom property ``splicer_timemap_<side>`` of ``obj`` in ``action``; returns the F-curve."""
    prop = TIMEMAP_PROP.format(side=side)
    tm = np.asarray(time_map, dtype=np.float64)
    obj[prop] = float(np.nanmin(tm)) if np.isfinite(tm).any() else 0.0
    fc = action.fcurve_ensure_for_datablock(obj, f'["{prop}"]', index=0, group_name="splicer time map")
    ok = np.flatnonzero(np.isfinite(tm))
    kp = fc.keyframe_points
    kp.clear()
    kp.add(len(ok))
    co = np.empty(2 * len(ok), dtype=np.float32)
    co[0::2] = ok + first
    co[1::2] = tm[ok]
    kp.foreach_set("co", co)
    kp.foreach_set("interpolation", np.full(len(ok), 1, dtype=np.int32))  # LINEAR: edits stay local
    fc.update()
    return fc


def fcurve_to_time_map(obj, side: str, n_body: int, first: int, action=None) -> np.ndarray:
    """The (possibly edited) time map F-curve evaluated at every body frame, shape (n_body,);
    NaN outside the keyed range (uncovered frames stay uncovered)."""
    action = action or obj.animation_data.action
    prop = TIMEMAP_PROP.format(side=side)
    fc = _find_fcurve(action, obj, f'["{prop}"]')
    if fc is None:
        raise _sub("errors").SplicerError(f"{obj.name}: no time map for the {side} side (splice first)")
    keys = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
    fc.keyframe_points.foreach_get("co", keys)
    lo, hi = float(keys[0::2].min()), float(keys[0::2].max())
    frames = np.arange(n_body) + first
    out = np.array([fc.evaluate(float(f)) for f in frames], dtype=np.float64)
    out[(frames < lo - 1e-6) | (frames > hi + 1e-6)] = np.nan
    return out


def _find_fcurve(action, obj, data_path: str):
    """The F-curve ``data_path`` (index 0) of ``action`` (Blender 4.4+ layered actions), or None."""
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                fc = bag.fcurves.find(data_path, index=0)
                if fc is not None:
                    return fc
    return None


def _options(settings: dict):
    return _sub("options").resolve_options(None, dict(settings or {}))


def splice_armatures(body_obj, hands_obj, *, scene=None, options: dict | None = None, config=None):
    """Splice the hands armature's fingers onto the body armature as a NEW action.

    Parameters
    ----------
    body_obj, hands_obj : bpy.types.Object
        Armatures in the scene, each with its take as the active action.
    options : dict, optional
        :class:`splicer.options.SpliceOptions` fields (``side``, ``band1``, ``merge``, ...).
    config : SpliceConfig, optional
        Default: the pins from the scene's timeline markers (:func:`markers_to_pins`).

    Returns
    -------
    (action, SpliceResult)
        The new action (assigned to ``body_obj``; the previous one is kept) and splicer's result.
    """
    import bpy

    scene = scene or bpy.context.scene
    pipeline, fbx = _sub("pipeline"), _sub("io.fbx")
    src_action = body_obj.animation_data.action if body_obj.animation_data else None
    if src_action is None:
        raise _sub("errors").SplicerError(f"{body_obj.name}: the body armature has no action")
    body = armature_motion(body_obj)
    hands = armature_motion(hands_obj)
    if config is None:
        config = _object_config(body_obj, hands_obj, scene)
    result = pipeline.splice(body, hands, config=config, **dict(options or {}))
    first = first_frame(body_obj)
    action = fbx.bake_action(body_obj, result.motion, name=f"{src_action.name}_spliced", frame_start=first)
    action["splicer_source_action"] = src_action.name
    for side, r in result.sides.items():
        time_map_to_fcurve(body_obj, action, side, r.hands_frame, first)
    body_obj[RESULT_PROP] = json.dumps({"hands": hands_obj.name, "source_action": src_action.name,
                                        "options": dict(options or {}), "sides": list(result.sides)})
    mark_ranges(scene, result.report, first)
    scene["splicer_report"] = json.dumps(report_summary(result.report))
    return action, result


def reapply_time_map(body_obj, *, scene=None):
    """Re-sample the fingers at the (edited) time map F-curves of ``body_obj``'s spliced action,
    without re-solving the alignment; the action's finger keys are replaced.  Returns the Motion."""
    import bpy

    scene = scene or bpy.context.scene
    pipeline, fbx = _sub("pipeline"), _sub("io.fbx")
    errors = _sub("errors")
    info = json.loads(body_obj.get(RESULT_PROP, "{}") or "{}")
    if not info:
        raise errors.SplicerError(f"{body_obj.name}: not spliced yet (no {RESULT_PROP} property)")
    hands_obj = bpy.data.objects.get(info["hands"])
    src = bpy.data.actions.get(info["source_action"])
    if hands_obj is None or src is None:
        raise errors.SplicerError(f"{body_obj.name}: the hands armature {info['hands']!r} or the body's original "
                                  f"action {info['source_action']!r} is gone")
    action = body_obj.animation_data.action
    body = armature_motion(body_obj, action=src)
    hands = armature_motion(hands_obj)
    first = first_frame(body_obj)
    opts = _options(info.get("options"))
    log = pipeline.Log()
    inputs = pipeline.load_inputs(body, hands, _object_config(body_obj, hands_obj, scene), log)
    rig = pipeline.find_rig(inputs, opts, log)
    checked = pipeline.condition_hands(inputs, rig, opts, log)
    inputs, out = checked.inputs, checked.inputs.body
    n = body.n_frames
    joints = set()
    for side in info["sides"]:
        tm = fcurve_to_time_map(body_obj, side, n, first, action)
        tm = np.clip(tm, 0, hands.n_frames - 1)
        ok = np.flatnonzero(np.isfinite(tm))
        covered = None if len(ok) == n else (int(ok[0]), int(ok[-1]))
        per_frame = inputs.spaces.hands_to_common(np.where(np.isfinite(tm), tm, 0.0))
        path = np.stack([np.arange(n, dtype=np.float64), per_frame], axis=1)
        aln = pipeline.Alignment(per_frame, path, None, None, (), covered)
        tr = pipeline.transfer_side(out, inputs, rig, side, aln, tm, opts, log)
        out = tr.motion
        joints |= set(tr.joints)
    fbx.bake_action(body_obj, out, frame_start=first, joints=sorted(joints), action=action)
    return out


def mark_ranges(scene, report, first: float) -> None:
    """Low-confidence and uncovered ranges as timeline markers (old ``splicer:`` markers removed)."""
    for mk in [m for m in scene.timeline_markers if m.name.startswith(_RANGE_PREFIX)]:
        scene.timeline_markers.remove(mk)
    for side, sr in report["sides"].items():
        for key, label in (("low_confidence", "low"), ("uncovered", "uncovered")):
            for a, b in (sr.get(key) or []):
                scene.timeline_markers.new(f"{_RANGE_PREFIX}{side} {label} {a}-{b}", frame=int(round(a + first)))


def report_summary(report) -> dict:
    """The panel's summary: per side the passes' costs, pins, uncovered and low-confidence
    ranges (body file frames), and the warnings."""
    d = report.to_dict() if hasattr(report, "to_dict") else dict(report)
    sides = {}
    for s, sr in d.get("sides", {}).items():
        sides[s] = {"pins": len(sr.get("constraints", [])),
                    "pass1_cost": (sr.get("pass1") or {}).get("cost"),
                    "pass2_cost": (sr.get("pass2") or {}).get("cost"),
                    "uncovered": sr.get("uncovered") or [], "low_confidence": sr.get("low_confidence") or [],
                    "joints": len(sr.get("joints", {}))}
    return {"body_frames": d.get("body", {}).get("frames"), "hands_frames": d.get("hands", {}).get("frames"),
            "sides": sides, "warnings": list(d.get("warnings", []))}
