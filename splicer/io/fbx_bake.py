"""Motion -> Blender armature (needs ``bpy``): :func:`new_armature` builds an armature from a
:class:`~splicer.model.Skeleton`, :func:`bake_action` keys a :class:`~splicer.model.Motion` on it as
a new action.  The inverse of :func:`splicer.io.fbx_armature.armature_motion`; the mapping is
described there.
"""

from __future__ import annotations

import numpy as np

from ..model.motion import Motion, Skeleton
from .fbx_armature import AXIS_CONVERSION, FBXError, _bpy, _mat, _orthonormal

__all__ = ["new_armature", "bake_action"]


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
