"""Render the spliced hand of the bundled sample headless with Blender (workbench engine).

    python benchmarks/blender_render.py -o benchmarks/blender_hand.png [--frame 300]

Blender's UI cannot be drawn by the ``bpy`` module (no window), so this shows the result
instead of the panel: the sample imported with Blender's BVH importer, spliced by the add-on's
logic (:func:`splicer.blender.core.splice_armatures`, pins from timeline markers), each bone
shown as a tapered stick; left: the body's left hand after the splice at the body frame,
right: the hands take at the frame the time map chose for it.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PINS = [(90, 347), (240, 836), (390, 1245), (520, 1671)]


def _sticks(bpy, obj, prefix: str, radius: float, color):
    """A tapered cone per bone under ``prefix`` (parented to the bone, so it follows the pose)."""
    mat = bpy.data.materials.new(f"{obj.name}_mat")
    mat.diffuse_color = color
    for b in obj.data.bones:
        if not b.name.startswith(prefix):
            continue
        length = b.length
        bpy.ops.mesh.primitive_cone_add(vertices=12, radius1=radius, radius2=radius * 0.6, depth=length,
                                        location=(0, 0, 0))
        cone = bpy.context.object
        cone.data.materials.append(mat)
        # cones point along +Z; a bone points along its +Y: rotate, and centre on the bone
        cone.rotation_euler = (-1.5708, 0, 0)
        cone.location = (0, -length / 2, 0)  # parent_type BONE puts the origin at the bone's tail
        cone.parent = obj
        cone.parent_type = "BONE"
        cone.parent_bone = b.name


def _render(bpy, scene, obj, bone: str, frame, path: str):
    import mathutils

    scene.frame_set(int(frame), subframe=frame - int(frame))
    pb = obj.pose.bones[bone]
    m = obj.matrix_world @ pb.matrix
    heads = [obj.matrix_world @ q.head for q in obj.pose.bones if q.name.startswith(bone)]
    target = sum(heads, mathutils.Vector()) / len(heads)  # the middle of the hand
    cam = scene.camera
    side = m.to_3x3() @ mathutils.Vector((0, 0, 1))  # across the palm: the bone's Z axis
    cam.location = target + side.normalized() * 26 + mathutils.Vector((0, 0, 8))
    direction = target - cam.location
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default=str(ROOT / "benchmarks" / "blender_hand.png"))
    p.add_argument("--frame", type=int, default=300, help="body frame to show (0-based)")
    a = p.parse_args(argv)

    import bpy
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from splicer.blender import core

    bpy.ops.wm.read_factory_settings(use_empty=True)
    objs = {}
    for k in ("body", "hands"):
        bpy.ops.import_anim.bvh(filepath=str(ROOT / "motions" / f"sample_{k}.bvh"), update_scene_fps=k == "body",
                                use_fps_scale=k == "hands", rotate_mode="QUATERNION")
        objs[k] = bpy.context.object
    scene = bpy.context.scene
    b0, h0, hs = core.first_frame(objs["body"]), core.first_frame(objs["hands"]), core.take_step(objs["hands"])
    for b, h in PINS:
        scene.timeline_markers.new(f"pin:{h0 + h * hs:g}", frame=int(b0 + b))
    _, result = core.splice_armatures(objs["body"], objs["hands"], scene=scene)
    _sticks(bpy, objs["body"], "LeftHand", 0.35, (0.85, 0.45, 0.25, 1.0))
    _sticks(bpy, objs["hands"], "LeftHand", 0.35, (0.25, 0.5, 0.85, 1.0))
    _sticks(bpy, objs["body"], "LeftForeArm", 0.9, (0.6, 0.6, 0.6, 1.0))
    _sticks(bpy, objs["hands"], "LeftForeArm", 0.9, (0.6, 0.6, 0.6, 1.0))
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.lens = 50
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "MATERIAL"
    scene.render.resolution_x, scene.render.resolution_y = 480, 480
    scene.render.film_transparent = False
    scene.world = bpy.data.worlds.new("w")
    tm = float(result.sides["left"].hands_frame[a.frame])
    with tempfile.TemporaryDirectory() as tmp:
        objs["hands"].hide_render = True
        for o in bpy.data.objects:
            if o.parent is objs["hands"]:
                o.hide_render = True
        _render(bpy, scene, objs["body"], "LeftHand", b0 + a.frame, f"{tmp}/body.png")
        for o in bpy.data.objects:
            o.hide_render = o.parent is objs["body"]
        _render(bpy, scene, objs["hands"], "LeftHand", h0 + tm * hs, f"{tmp}/hands.png")
        fig, axes = plt.subplots(1, 2, figsize=(8, 4.2))
        for ax, f, title in ((axes[0], "body.png", f"spliced body, frame {a.frame}"),
                             (axes[1], "hands.png", f"hands take, frame {tm:.1f} (time map)")):
            ax.imshow(plt.imread(f"{tmp}/{f}"))
            ax.set_title(title, fontsize=9)
            ax.axis("off")
        fig.suptitle("Left hand rendered headless by Blender 5.0 (workbench), spliced by the add-on", fontsize=10)
        fig.tight_layout()
        fig.savefig(a.output, dpi=100)
    print(f"wrote {a.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
