"""FBX in and out through Blender's own FBX importer and exporter (the ``bpy`` module).

This is the one core module that touches ``bpy`` (``pip install "splicer[blender]"``).  It
has two layers:

* **Armature <-> Motion** (need ``bpy``; used by the Blender add-on and by the FBX worker):
  :func:`armature_motion` samples an armature's animation into a :class:`~splicer.model.Motion`,
  :func:`bake_action` writes a Motion onto an armature as a new action, and
  :func:`new_armature` builds an armature from a :class:`~splicer.model.Skeleton`.
* **Files** (no ``bpy`` in the calling process): :func:`read_fbx` and :func:`write_fbx` run
  Blender in a child process (``python -m splicer.io.fbx``) and pass arrays through a
  temporary ``.npz``.  Importing ``bpy`` changes the process (``sys.path`` entries,
  environment variables, Blender's own message output, and a numpy-1.x audio module that
  complains under numpy 2), and an importer that fails (Blender 5.0's FBX importer fails on
  files with lights) must not take the splice down: so the file layer keeps Blender in its
  own process (about 2 s per file).

The armature layer and the mapping of an armature to the BVH-like model are in
:mod:`splicer.io.fbx_armature` (armature -> Motion) and :mod:`splicer.io.fbx_bake` (Motion ->
armature); their names are importable from here too.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion, Skeleton
from .fbx_armature import AXIS_CONVERSION, BPY_MISSING, FBXError, _bpy, _key_times, armature_motion, have_bpy  # noqa: F401
from .fbx_bake import bake_action, new_armature

__all__ = ["FBXError", "BPY_MISSING", "have_bpy", "read_fbx", "write_fbx", "armature_motion", "bake_action",
           "new_armature", "AXIS_CONVERSION"]


# ---------------------------------------------------------------- in the Blender process: files

def _empty_scene():
    bpy = _bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def _set_fps(scene, fps: float) -> None:
    base = int(round(fps))
    scene.render.fps = max(base, 1)
    scene.render.fps_base = scene.render.fps / fps


def import_fbx_armature(path: str):
    """Import ``path`` with Blender's FBX importer into the current scene; the armature object.

    A light in the file is read as a placeholder point light (Blender 5.0's importer fails
    on lights otherwise: ``'CyclesLightSettings' object has no attribute 'cast_shadow'``).
    ASCII FBX files are refused by the importer ("ASCII FBX files are not supported").

    Raises
    ------
    FBXError
        The importer fails (its last message line), or the file has no armature, or several
        of the same size (naming them).
    """
    bpy = _bpy()
    before = set(bpy.data.objects)
    # the importer scales by UnitScaleFactor / (100 * scene scale_length): undo it, so lengths are the file's
    scale = 100.0 * bpy.context.scene.unit_settings.scale_length / _fbx_unit_scale(path)
    restore = _lights_as_placeholders()
    try:
        res = bpy.ops.import_scene.fbx(filepath=str(path), use_anim=True, ignore_leaf_bones=False,
                                       automatic_bone_orientation=False, global_scale=scale,
                                       use_custom_props=False, use_image_search=False)
    except Exception as e:  # noqa: BLE001 - the importer raises anything; one line for the user
        lines = [ln.strip() for ln in str(e).splitlines() if ln.strip() and not ln.startswith("Location:")]
        msg = lines[-1] if lines else type(e).__name__
        raise FBXError(f"{path}: Blender's FBX importer failed: {msg.removeprefix('Error: ')}") from None
    finally:
        restore()
    if "FINISHED" not in res:
        raise FBXError(f"{path}: Blender's FBX importer could not read the file")
    arms = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    if not arms:
        raise FBXError(f"{path}: no armature (skeleton) in the FBX file")
    if len(arms) > 1:
        arms.sort(key=lambda o: -len(o.data.bones))
        if len(arms[0].data.bones) == len(arms[1].data.bones):
            raise FBXError(f"{path}: {len(arms)} armatures ({', '.join(o.name for o in arms)}); keep one per file")
    return arms[0]


def _lights_as_placeholders():
    """Work around Blender 5.0's FBX importer failing on any light (``lamp.cycles.cast_shadow``
    no longer exists): while importing, a light becomes a plain point light (lights do not
    matter here).  Returns the function that restores the importer."""
    try:
        from io_scene_fbx import import_fbx
    except ImportError:
        return lambda: None
    original = import_fbx.blen_read_light

    def placeholder(fbx_tmpl, fbx_obj, settings):
        import bpy

        return bpy.data.lights.new(name="fbx light", type="POINT")

    import_fbx.blen_read_light = placeholder

    def restore():
        import_fbx.blen_read_light = original

    return restore


def _fbx_unit_scale(path) -> float:
    """The file's ``UnitScaleFactor`` (centimetres per file unit; 1.0 when absent or unreadable)."""
    try:
        from io_scene_fbx import parse_fbx
        from io_scene_fbx.fbx_utils import elem_find_first
        from io_scene_fbx.import_fbx import elem_props_get_number

        root, _ = parse_fbx.parse(str(path))
        props = elem_find_first(elem_find_first(root, b"GlobalSettings"), b"Properties70")
        u = float(elem_props_get_number(props, b"UnitScaleFactor", 1.0))
    except Exception:  # noqa: BLE001 - the importer itself then reports what is wrong with the file
        return 1.0
    return u if u > 0 and np.isfinite(u) else 1.0


def _read_in_blender(path: str) -> Motion:
    scene = _empty_scene()
    obj = import_fbx_armature(path)
    ad = obj.animation_data
    if ad is None or ad.action is None:
        raise FBXError(f"{path}: the armature {obj.name!r} has no animation")
    return armature_motion(obj, source=str(path), scene=scene, leaf_tails=False)


def _write_in_blender(motion: Motion, path: str) -> None:
    bpy = _bpy()
    scene = _empty_scene()
    _set_fps(scene, motion.fps)
    scene.frame_start, scene.frame_end = 1, motion.n_frames
    name = Path(motion.source).stem if motion.source else "splicer"
    obj = new_armature(motion.skeleton, name, leaf_bones=True, aligned=True)
    # Blender's exporter writes each bone's node transform at the current frame, and an importer takes
    # those as the rest pose of an armature without a mesh: key the rest pose at frame 0 (outside the
    # exported range 1..T) and export from there.
    sk = motion.skeleton
    rest = np.zeros((1, sk.n_channels))
    rest[0, sk.position_columns(0)] = sk.offsets[0]
    bake_action(obj, motion.with_channels(np.vstack([rest, motion.channels])), name=f"{name}_action", frame_start=0)
    scene.frame_set(0)
    for o in bpy.data.objects:
        o.select_set(o is obj)
    bpy.context.view_layer.objects.active = obj
    res = bpy.ops.export_scene.fbx(filepath=str(path), use_selection=True, object_types={"ARMATURE"},
                                   add_leaf_bones=False, bake_anim=True, bake_anim_use_all_actions=False,
                                   bake_anim_use_nla_strips=False, bake_anim_simplify_factor=0.0,
                                   bake_anim_force_startend_keying=True, apply_unit_scale=False,
                                   apply_scale_options="FBX_SCALE_NONE", global_scale=0.01,  # numbers as they are
                                   use_armature_deform_only=False, primary_bone_axis="Y", secondary_bone_axis="X",
                                   axis_forward="-Z", axis_up="Y")
    if "FINISHED" not in res:
        raise FBXError(f"{path}: Blender's FBX exporter failed")


def _motion_to_npz(m: Motion, path: str, notes=()) -> None:
    sk = m.skeleton
    np.savez(path, names=np.array(sk.names, dtype=object), parents=sk.parents, offsets=sk.offsets,
             channels=np.array(["\t".join(c) for c in sk.channels], dtype=object), end_sites=sk.end_sites,
             data=m.channels, frame_time=m.frame_time, source=np.array(m.source or "", dtype=object),
             notes=np.array(list(notes), dtype=object))


def _motion_from_npz(path: str, source: str | None = None) -> Motion:
    import warnings

    from ..errors import SplicerWarning

    z = np.load(path, allow_pickle=True)
    for note in z["notes"] if "notes" in z.files else ():
        warnings.warn(str(note), SplicerWarning, stacklevel=3)  # collected into the report by load_inputs
    sk = Skeleton(tuple(str(n) for n in z["names"]), z["parents"], z["offsets"],
                  tuple(tuple(str(c).split("\t")) if c else () for c in z["channels"]), z["end_sites"])
    return Motion(sk, z["data"], float(z["frame_time"]), source or str(z["source"].item()) or None)


# ---------------------------------------------------------------- the calling process: files

def _run_worker(args: list[str], what: str) -> None:
    if not have_bpy():
        raise FBXError(BPY_MISSING)
    env = dict(os.environ)
    here = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = here + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.run([sys.executable, "-m", "splicer.io.fbx", *args], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("splicer-fbx: ")]
        msg = lines[-1][len("splicer-fbx: "):] if lines else (proc.stderr.strip().splitlines() or ["unknown error"])[-1]
        raise FBXError(msg if lines else f"{what}: Blender failed: {msg}")


def read_fbx(path: str | os.PathLike) -> Motion:
    """Read the animated armature of an FBX file (Blender's importer, in a child process).

    Returns
    -------
    Motion
        See the module notes for the mapping (file axes and units, ZXY channels, every frame).

    Raises
    ------
    FBXError
        ``bpy`` missing, no such file, no armature or animation, or the importer failed.
    """
    spath = str(path)
    if not Path(spath).is_file():
        raise FBXError(f"{spath}: no such file")
    with tempfile.TemporaryDirectory(prefix="splicer-fbx-") as tmp:
        out = os.path.join(tmp, "motion.npz")
        _run_worker(["read", os.path.abspath(spath), out], spath)
        return _motion_from_npz(out, source=spath)


def write_fbx(motion: Motion, path: str | os.PathLike) -> None:
    """Write ``motion`` as an FBX armature with its animation (Blender's exporter, in a child process).

    The file appears complete or not at all (:func:`splicer.atomic.write_atomic`; inside a
    :class:`~splicer.atomic.Transaction` it is staged like every other output).

    Raises
    ------
    FBXError
        ``bpy`` missing or the exporter failed; ``path`` is then untouched.
    """
    from .atomic import write_atomic

    spath = str(path)
    if not isinstance(motion, Motion):
        raise TypeError(f"write_fbx expects a Motion, got {type(motion).__name__}")
    if not Path(spath).resolve().parent.is_dir():
        raise FBXError(f"{spath}: cannot write: directory {str(Path(spath).parent)!r} does not exist")
    with tempfile.TemporaryDirectory(prefix="splicer-fbx-") as tmp:
        src, out = os.path.join(tmp, "motion.npz"), os.path.join(tmp, "out.fbx")
        _motion_to_npz(motion, src)
        _run_worker(["write", src, out], spath)
        data = Path(out).read_bytes()
    write_atomic(spath, lambda f: f.write(data), what="file", error=lambda message: FBXError(f"{spath}: {message}"))


def _main(argv: list[str]) -> int:
    import warnings

    from ..errors import SplicerWarning

    warnings.simplefilter("ignore")
    try:
        if len(argv) == 3 and argv[0] == "read":
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", SplicerWarning)
                m = _read_in_blender(argv[1])
            _motion_to_npz(m, argv[2], [str(w.message) for w in caught if issubclass(w.category, SplicerWarning)])
        elif len(argv) == 3 and argv[0] == "write":
            _write_in_blender(_motion_from_npz(argv[1]), argv[2])
        else:
            print("splicer-fbx: usage: python -m splicer.io.fbx read IN.fbx OUT.npz | write IN.npz OUT.fbx",
                  file=sys.stderr)
            return 2
    except SplicerError as e:
        print(f"splicer-fbx: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
