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

The mapping to the BVH-like model
---------------------------------
An armature becomes a :class:`~splicer.model.Skeleton` as follows:

* **joints** = bones, parents before children (Blender's bone order is depth-first);
  names are the bone names.  A childless bone named ``<parent>_end`` (Blender's FBX
  "leaf bones") or ``*Nub`` (3ds Max) is not a joint: its head is its parent's **End Site**.
  Any other childless bone has no End Site when read from an FBX file (FBX has no bone
  tails; the importer guesses them) and its tail as End Site when read from an armature in
  a scene (Blender's BVH importer puts it there).
* **axes and units**: coordinates are the file's own.  Blender's importers (BVH and FBX,
  default settings) convert a Y-up file to Blender's Z-up world with ``world = C @ file``,
  ``C = axis_conversion(from_forward="-Z", from_up="Y")``; we undo exactly that
  (``file = C.T @ world``, world = the armature object's world matrix times armature
  space), so a Y-up file reads back in its own axes.  FBX is imported without unit
  scaling (``apply_unit_scale=False``): lengths are the file's numbers (centimetres for
  most FBX files), like BVH.
* **rest pose**: the armature's rest pose is the skeleton's rest pose with every joint
  frame aligned with the file axes (BVH's convention).  ``offsets[j]`` is the rest head of
  bone ``j`` minus its parent's (the root: its rest head), so bone orientations and rolls
  do not matter.
* **channels**: the root gets ``Xposition Yposition Zposition Zrotation Xrotation
  Yrotation``, every other joint ``Zrotation Xrotation Yrotation`` (degrees, unwrapped
  over time).  Each joint's rotation is its local rotation relative to its parent in the
  rest frame: with ``P_j`` the posed and ``A_j`` the rest world rotation of bone ``j``
  (both in file axes), ``G_j = P_j A_j^T`` and ``R_j = G_parent^T G_j``.  The root
  position is the posed root head.  Non-root bone translation and bone scale are not
  carried (a warning when they are animated).
* **frames**: every integer frame of the action's frame range is sampled with the scene
  evaluated there (constraints and drivers included); ``frame_time = fps_base / fps``.

Writing does the inverse: bones with heads at the rest positions (``world = C @ file``),
the pose basis ``B_j = A_j^T R_j A_j`` (armature space) keyed as quaternions on every frame,
the root location keyed, then Blender's FBX exporter (armature only, every frame baked,
no key reduction, leaf bones added so End Sites survive, Y up / -Z forward).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion, Skeleton

__all__ = ["FBXError", "BPY_MISSING", "have_bpy", "read_fbx", "write_fbx", "armature_motion", "bake_action",
           "new_armature", "AXIS_CONVERSION"]

BPY_MISSING = 'FBX needs Blender\'s bpy: pip install "splicer[blender]"'

# world (Blender, Z up) = AXIS_CONVERSION @ file (Y up, -Z forward): Blender's importers' default
AXIS_CONVERSION = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_END_SUFFIXES = ("Nub",)
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
_JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")


class FBXError(SplicerError):
    """An FBX file that cannot be read or written (or Blender is missing)."""


def have_bpy() -> bool:
    """True when Blender's ``bpy`` module can be imported here (without importing it)."""
    try:
        return importlib.util.find_spec("bpy") is not None
    except (ImportError, ValueError):
        return False


def _bpy():
    try:
        import bpy
    except ImportError:
        raise FBXError(BPY_MISSING) from None
    return bpy


def _is_end_bone(bone) -> bool:
    """A childless bone that only marks its parent's end: Blender's FBX leaf bone ``<parent>_end``,
    or 3ds Max's ``*Nub``.  (A joint merely named ``...End``, as in ZEGGS, is a joint.)"""
    if bone.children or bone.parent is None:
        return False
    return bone.name == f"{bone.parent.name}_end" or bone.name.endswith(_END_SUFFIXES)


# ---------------------------------------------------------------- armature -> Motion (needs bpy)

def _mat(m) -> np.ndarray:
    return np.array([list(r) for r in m], dtype=np.float64)


def _orthonormal(m: np.ndarray) -> np.ndarray:
    """The rotation of a rotation-times-uniform-scale matrix (polar factor)."""
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def _basis_rotations(mode: str, quat, euler, axis_angle) -> np.ndarray:
    """A pose bone's own rotation channels over frames (``matrix_basis`` rotations), as double
    precision matrices (T, 3, 3), from the values of its rotation mode (float32 arrays)."""
    from ..model.rotations import quat_from_euler, quat_normalize, quat_to_matrix

    if mode == "QUATERNION":
        q = quat_normalize(np.asarray(quat, dtype=np.float64))
    elif mode == "AXIS_ANGLE":
        aa = np.asarray(axis_angle, dtype=np.float64)
        axis = aa[:, 1:]
        nrm = np.linalg.norm(axis, axis=1, keepdims=True)
        axis = np.where(nrm > 0, axis / np.where(nrm > 0, nrm, 1.0), [0.0, 1.0, 0.0])
        q = np.concatenate([np.cos(aa[:, :1] / 2), np.sin(aa[:, :1] / 2) * axis], axis=1)
    else:  # Blender's Euler 'XYZ' applies X first: M = Rz Ry Rx, i.e. intrinsic "ZYX" with (z, y, x)
        e = np.degrees(np.asarray(euler, dtype=np.float64))
        order = mode[::-1]
        q = quat_from_euler(e[:, ["XYZ".index(a) for a in order]], order)
    return quat_to_matrix(q)


def _key_times(action) -> np.ndarray:
    """Sorted distinct key times (scene frames) of every F-curve of ``action`` that animates a bone."""
    out = []
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                for fc in bag.fcurves:
                    if fc.data_path.startswith("pose.bones") and len(fc.keyframe_points):
                        co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
                        fc.keyframe_points.foreach_get("co", co)
                        out.append(co[0::2])
    if not out:
        return np.zeros(0)
    t = np.unique(np.round(np.concatenate(out).astype(np.float64), 4))
    return t


def armature_motion(obj, *, frames=None, source: str | None = None, scene=None, leaf_tails: bool = True) -> Motion:
    """Sample an armature object's animation into a BVH-like Motion (see the module notes).

    Parameters
    ----------
    obj : bpy.types.Object
        An armature object (its active action is what the scene evaluates).
    frames : sequence of float, optional
        Scene frames to sample; default the action's own key times: from its first to its
        last bone key in steps of the median key spacing (1 for a take at the scene's rate;
        0.5 for a 60 fps BVH imported into a 30 fps scene with "scale FPS"), the take's
        rate being the scene's divided by that step.  Without an action: the scene range.
    source : str, optional
        Recorded as ``Motion.source`` (default the object's name).
    scene : bpy.types.Scene, optional
        Default the current scene; its frame is restored afterwards.
    leaf_tails : bool
        A childless bone without an end bone gets its tail as End Site (True: Blender's BVH
        importer puts the End Site there) or none (False: an FBX has no tails; the importer
        guesses them).

    Returns
    -------
    Motion
        ``frame_time``: the take's own (see ``frames``); lengths in world units, file axes.
    """
    from ..model.rotations import quat_from_matrix

    bpy = _bpy()
    if obj is None or obj.type != "ARMATURE":
        raise FBXError(f"{getattr(obj, 'name', obj)!r} is not an armature")
    scene = scene or bpy.context.scene
    arm = obj.data
    bones = [b for b in arm.bones if not _is_end_bone(b)]
    if not bones:
        raise FBXError(f"armature {obj.name!r} has no bones")
    index = {b.name: k for k, b in enumerate(bones)}
    parents = np.array([index[b.parent.name] if b.parent is not None else -1 for b in bones], dtype=np.int64)
    for j, p in enumerate(parents):
        if p >= j:  # Blender lists bones depth-first; a different order would break "parents first"
            raise FBXError(f"armature {obj.name!r}: bone {bones[j].name!r} comes before its parent")
    scene_fps = scene.render.fps / scene.render.fps_base
    fps = scene_fps
    if frames is None:
        ad = obj.animation_data
        times = _key_times(ad.action) if ad is not None and ad.action is not None else np.zeros(0)
        if len(times) > 1:
            # a take at another rate than the scene's (BVH imported with "scale FPS") has its keys every
            # `step` scene frames: sample at its own keys, and its rate is scene_fps / step
            step = float(np.median(np.diff(times)))
            step = step if abs(step - round(step)) > 1e-3 else float(round(step))
            n = int(round((times[-1] - times[0]) / step)) + 1
            # the keys themselves when there is one per frame (an importer may let them drift off whole
            # frames by a fraction, e.g. at 120.0005 fps); else a regular grid
            frames = times if len(times) == n else times[0] + step * np.arange(n)
            fps = scene_fps / step
        else:
            frames = range(scene.frame_start, scene.frame_end + 1)
    frames = [float(f) for f in frames]
    C = AXIS_CONVERSION
    J, T = len(bones), len(frames)
    # rest, in file axes: heads and rotations from the object's world matrix at the current frame
    W0 = _mat(obj.matrix_world)
    K0 = C.T @ W0[:3, :3]
    t0 = C.T @ W0[:3, 3]
    heads = np.array([K0 @ np.array(b.head_local) + t0 for b in bones])
    R0 = _orthonormal(K0)
    rest_rot = np.array([R0 @ _orthonormal(_mat(b.matrix_local)[:3, :3]) for b in bones])
    offsets = heads - np.where(parents[:, None] >= 0, heads[np.maximum(parents, 0)], 0.0)
    ends = np.full((J, 3), np.nan)
    for j, b in enumerate(bones):
        end_kids = [c for c in b.children if _is_end_bone(c)]
        if end_kids:
            ends[j] = K0 @ np.array(end_kids[0].head_local) + t0 - heads[j]
        elif not b.children and leaf_tails:
            ends[j] = K0 @ np.array(b.tail_local) + t0 - heads[j]
    pose = obj.pose.bones
    pidx = np.array([pose.find(b.name) for b in bones])  # pose bone index of each joint
    NP = len(pose)
    A = np.array([_mat(b.matrix_local) for b in bones])  # rest, armature space (float32 in Blender)
    A[:, :3, :3] = [_orthonormal(a) for a in A[:, :3, :3]]
    modes = [pose[int(i)].rotation_mode for i in pidx]
    W_all = np.empty((T, 4, 4))
    M_all = np.empty((T, NP, 16), dtype=np.float32)
    quat = np.empty((T, NP, 4), dtype=np.float32)
    eul = np.empty((T, NP, 3), dtype=np.float32)
    axang = np.empty((T, NP, 4), dtype=np.float32)
    loc = np.empty((T, NP, 3), dtype=np.float32)
    keep = scene.frame_current, scene.frame_subframe
    try:
        for t, f in enumerate(frames):
            scene.frame_set(int(np.floor(f + 1e-6)), subframe=max(0.0, f - np.floor(f + 1e-6)))
            W_all[t] = _mat(obj.matrix_world)
            pose.foreach_get("matrix", M_all[t].ravel())
            pose.foreach_get("rotation_quaternion", quat[t].ravel())
            pose.foreach_get("rotation_euler", eul[t].ravel())
            pose.foreach_get("rotation_axis_angle", axang[t].ravel())
            pose.foreach_get("location", loc[t].ravel())
    finally:
        scene.frame_set(keep[0], subframe=keep[1])
    # matrices come flat in column-major order (Blender's float[4][4] is [column][row])
    M = np.swapaxes(M_all[:, pidx].astype(np.float64).reshape(T, J, 4, 4), -1, -2)
    K = C.T @ W_all[:, :3, :3]  # (T, 3, 3)
    R = np.array([_orthonormal(k) for k in K]) if T else np.zeros((0, 3, 3))
    tw = (C.T @ W_all[:, :3, 3:])[..., 0]  # (T, 3)
    s_arm = float(np.cbrt(abs(np.linalg.det(K0)))) or 1.0  # armature units -> file units
    G = R[:, None] @ M[..., :3, :3] @ np.swapaxes(rest_rot, -1, -2)[None]
    # the local rotation from the bones' own channels, in double precision: R_j = A_j B_j A_j^T
    B = np.empty((T, J, 3, 3))
    for j, mode in enumerate(modes):
        i = int(pidx[j])
        B[:, j] = _basis_rotations(mode, quat[:, i], eul[:, i], axang[:, i])
    Ar = R0 @ A[:, :3, :3]  # (J, 3, 3)
    local = Ar[None] @ B @ np.swapaxes(A[:, :3, :3], -1, -2)[None] @ R0.T
    root_pos = (K @ M[:, 0, :3, 3:])[..., 0] + tw
    basis_pos = (K @ (A[0, :3, 3] + loc[:, int(pidx[0])].astype(np.float64) @ A[0, :3, :3].T)[..., None])[..., 0] + tw
    # a bone's own translation channels, beyond float noise (1e-4 of the skeleton's size)
    size = max(float(np.abs(heads - heads[0]).max(initial=0.0)), 1e-12)
    moved = {bones[j].name for j in range(1, J) if np.abs(loc[:, int(pidx[j])]).max(initial=0.0) * s_arm > 1e-4 * size}
    # where constraints, drivers or unusual inheritance make the evaluated pose differ from the bones'
    # own channels, the evaluated pose (float32 through the chain) is the truth
    from_pose = np.empty_like(G)
    for j in range(J):
        p = parents[j]
        from_pose[:, j] = G[:, j] if p < 0 else np.transpose(G[:, p], (0, 2, 1)) @ G[:, j]
    differs = np.abs(from_pose - local).max(axis=(0, 2, 3)) > 1e-4  # ~0.006 degrees
    local[:, differs] = from_pose[:, differs]
    if np.abs(basis_pos - root_pos).max() <= 1e-4 * max(1.0, float(np.abs(root_pos).max())) and not differs[0]:
        root_pos = basis_pos
    q = quat_from_matrix(local)  # (T, J, 4)
    if (parents[1:] < 0).any():
        roots = ", ".join(bones[j].name for j in np.flatnonzero(parents < 0))
        raise FBXError(f"armature {obj.name!r}: several root bones ({roots}); one skeleton needs one root")
    channels = [_ROOT_CHANNELS if j == 0 else _JOINT_CHANNELS for j in range(J)]
    sk = Skeleton(tuple(b.name for b in bones), parents, offsets, tuple(channels), ends)
    m = Motion(sk, np.zeros((T, sk.n_channels)), 1.0 / fps, source or obj.name)
    m = m.with_rotations(range(J), q).with_translations(0, root_pos)
    if moved:
        import warnings

        from ..errors import SplicerWarning

        warnings.warn(f"{source or obj.name}: bones {', '.join(sorted(moved)[:5])} have animated translation; "
                      "only rotations (and the root position) are read", SplicerWarning, stacklevel=2)
    return m


# ---------------------------------------------------------------- Motion -> armature (needs bpy)

def _world_heads(sk: Skeleton) -> np.ndarray:
    """Rest heads in file axes (root at its offset)."""
    heads = np.zeros((sk.n_joints, 3))
    for j in range(sk.n_joints):
        p = sk.parents[j]
        heads[j] = sk.offsets[j] + (heads[p] if p >= 0 else 0.0)
    return heads


def new_armature(skeleton: Skeleton, name: str = "splicer", *, collection=None, leaf_bones: bool = False,
                 aligned: bool = False):
    """A new armature object whose rest pose is ``skeleton`` (heads at the rest joints, Z up).

    Bone tails point at the (mean of the) children, else the End Site, else continue the
    parent's direction; rolls are zero.  ``leaf_bones``: add a ``<name>_end`` bone at each End
    Site (so an FBX keeps them).  Returns the object (linked to ``collection`` or the scene's).
    """
    bpy = _bpy()
    C = AXIS_CONVERSION
    sk = skeleton
    heads = _world_heads(sk)
    scale = float(np.median(np.linalg.norm(sk.offsets[1:], axis=1))) if sk.n_joints > 1 else 1.0
    scale = scale if scale > 0 else 1.0
    data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, data)
    (collection or bpy.context.scene.collection).objects.link(obj)
    view_layer = bpy.context.view_layer
    prev_active = view_layer.objects.active
    view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        ebs = []
        for j, n in enumerate(sk.names):
            eb = data.edit_bones.new(n)
            kids = sk.children[j]
            h = heads[j]
            if kids:
                d = np.mean([heads[k] for k in kids], axis=0) - h
            elif np.all(np.isfinite(sk.end_sites[j])):
                d = sk.end_sites[j]
            elif sk.parents[j] >= 0:
                d = h - heads[sk.parents[j]]
            else:
                d = np.array([0.0, 1.0, 0.0])
            if np.linalg.norm(d) < 1e-4 * scale:
                d = np.array([0.0, 0.1 * scale, 0.0])
            if aligned:  # every bone's frame = the file axes (BVH's joint frames): bone Y along file +Y
                d = np.array([0.0, np.linalg.norm(d), 0.0])
            eb.head = C @ h
            eb.tail = C @ (h + d)
            eb.roll = 0.0
            if sk.parents[j] >= 0:
                eb.parent = ebs[sk.parents[j]]
            ebs.append(eb)
        if leaf_bones:
            for j, n in enumerate(sk.names):
                es = sk.end_sites[j]
                if np.all(np.isfinite(es)) and not sk.children[j]:
                    eb = data.edit_bones.new(f"{n}_end")
                    eb.head = C @ (heads[j] + es)
                    d = es if np.linalg.norm(es) > 1e-4 * scale else np.array([0.0, 0.1 * scale, 0.0])
                    d = np.array([0.0, np.linalg.norm(d), 0.0]) if aligned else d
                    eb.tail = C @ (heads[j] + es + 0.25 * d)
                    eb.parent = ebs[j]
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
        view_layer.objects.active = prev_active if prev_active is not None else obj
    return obj


def bake_action(obj, motion: Motion, *, name: str | None = None, frame_start: int = 1, joints=None, action=None):
    """Key ``motion`` onto armature ``obj`` as a NEW action (assigned to it); returns the action.

    Parameters
    ----------
    obj : bpy.types.Object
        An armature whose bones include the motion's joints by name (the rest pose must be the
        motion's skeleton up to bone orientation, e.g. the armature the motion was read from).
    motion : Motion
        Frame ``t`` is keyed at scene frame ``frame_start + t``.
    name : str, optional
        Action name (default ``"<object>_splicer"``).
    joints : iterable of str, optional
        Joints to key (default all of the motion's that the armature has).
    action : bpy.types.Action, optional
        Re-key these joints in this action (already assigned to ``obj``) instead of making a new one.

    Notes
    -----
    Each bone's rotation is keyed as a quaternion (``rotation_mode`` is set to
    ``QUATERNION``), the root's location too; the object's previous action is left
    untouched (still in ``bpy.data.actions``).
    """
    bpy = _bpy()
    from ..model.rotations import quat_from_matrix, quat_hemisphere, quat_to_matrix

    C = AXIS_CONVERSION
    sk = motion.skeleton
    W0 = _mat(obj.matrix_world)
    K0 = C.T @ W0[:3, :3]
    R0 = _orthonormal(K0)
    want = list(sk.names) if joints is None else list(joints)
    arm_bones = obj.data.bones
    missing = [n for n in want if n not in arm_bones]
    if joints is not None and missing:
        raise FBXError(f"armature {obj.name!r} has no bones {', '.join(missing[:5])}")
    want = [n for n in want if n in arm_bones]
    if obj.animation_data is None:
        obj.animation_data_create()
    if action is None:
        action = bpy.data.actions.new(name or f"{obj.name}_splicer")
        obj.animation_data.action = action
    T = motion.n_frames
    frames = np.arange(T, dtype=np.float64) + frame_start
    Rloc = quat_to_matrix(motion.rotations)  # (T, J, 3, 3), BVH-local, file axes
    for n in want:
        j = sk.index(n)
        b = arm_bones[n]
        A = R0 @ _mat(b.matrix_local)[:3, :3]  # rest rotation of the bone in file axes
        B = A.T @ Rloc[:, j] @ A  # the pose basis in bone space: A^T R A
        q = quat_hemisphere(quat_from_matrix(B), axis=0)
        pb = obj.pose.bones[n]
        pb.rotation_mode = "QUATERNION"
        _key(action, obj, f'pose.bones["{_esc(n)}"].rotation_quaternion', q, frames, group=n)
        if sk.parents[j] < 0 and sk.position_columns(j):
            pos = motion.joint_translations([j])[:, 0]  # file axes and units
            head = np.array(b.head_local)  # armature space
            # armature space = K0^-1 (file - t0); basis location = A_b^T (pose head - rest head) in bone space
            t0 = C.T @ W0[:3, 3]
            arm_pos = np.linalg.solve(K0, (pos - t0).T).T
            loc = (arm_pos - head) @ _mat(b.matrix_local)[:3, :3]
            _key(action, obj, f'pose.bones["{_esc(n)}"].location', loc, frames, group=n)
    return action


def _esc(name: str) -> str:
    return name.replace("\\", "\\\\").replace('"', '\\"')


def _key(action, obj, data_path: str, values: np.ndarray, frames: np.ndarray, group: str = "") -> None:
    """Key every column of ``values`` (T, k) on ``data_path`` at ``frames``, linear interpolation."""
    for i in range(values.shape[1]):
        fc = action.fcurve_ensure_for_datablock(obj, data_path, index=i, group_name=group)
        kp = fc.keyframe_points
        kp.clear()
        kp.add(len(frames))
        co = np.empty(2 * len(frames), dtype=np.float32)
        co[0::2] = frames
        co[1::2] = values[:, i]
        kp.foreach_set("co", co)
        kp.foreach_set("interpolation", np.full(len(frames), 1, dtype=np.int32))  # LINEAR
        fc.update()


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
