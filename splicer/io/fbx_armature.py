"""Blender armatures <-> :class:`~splicer.model.Motion` (needs ``bpy``): the armature layer of
:mod:`splicer.io.fbx`, used by the FBX worker and the Blender add-on.

:func:`armature_motion` samples an armature's animation, :func:`bake_action` writes a Motion
onto an armature as a new action, :func:`new_armature` builds an armature from a
:class:`~splicer.model.Skeleton`.

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

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion, Skeleton

__all__ = ["FBXError", "BPY_MISSING", "have_bpy", "armature_motion", "AXIS_CONVERSION"]

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
