"""FBX in and out, and the Blender add-on, in real Blender (the ``bpy`` module, background).

Skipped with a reason only where ``bpy`` cannot be imported (``pip install "splicer[blender]"``;
the wheel exists for CPython 3.11).  One Blender session per module: both sample takes are
imported once with Blender's BVH importer and spliced once; the tests read that scene.
"""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from splicer.io.fbx import have_bpy

pytestmark = pytest.mark.skipif(not have_bpy(), reason="bpy (Blender as a module) is not installed: "
                                "pip install 'splicer[blender]' (a wheel exists for CPython 3.11)")

ROOT = Path(__file__).resolve().parents[1]
BODY, HANDS, SYNC = (ROOT / "motions" / n for n in ("sample_body.bvh", "sample_hands.bvh", "sample_sync.yaml"))
PINS = [(90, 347), (240, 836), (390, 1245), (520, 1671)]  # sample_sync.yaml: (body, hands) file frames
FINGERS = ("Thumb", "Index", "Middle", "Ring", "Pinky")


def _angle(a, b):
    from splicer.model.rotations import quat_angle_deg

    return quat_angle_deg(a.rotations, b.rotations)


@pytest.fixture(scope="module")
def cli_bvh(tmp_path_factory):
    """The CLI's splice of the sample BVH files (the reference)."""
    from splicer.io.bvh import read_bvh
    from splicer.cli import main

    out = tmp_path_factory.mktemp("cli") / "out.bvh"
    assert main([str(BODY), str(HANDS), "-o", str(out), "--constraints", str(SYNC), "-q"]) == 0
    return read_bvh(out)


@pytest.fixture(scope="module")
def scene():
    """A Blender scene with the sample's armatures (Blender's BVH importer) and pins as markers.

    The body sets the scene rate (30 fps); the 60 fps hands are scaled into it (keys every half
    frame).  Imported with quaternion rotations: the default native-Euler import stores Euler
    angles in each bone's own axes, which lose up to 0.9 degrees of the file's rotation near
    gimbal lock (measured on this sample)."""
    import bpy

    from splicer.blender import core

    bpy.ops.wm.read_factory_settings(use_empty=True)
    objs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)  # Blender's BVH importer leaves its file to the collector
        for k, path in (("body", BODY), ("hands", HANDS)):
            bpy.ops.import_anim.bvh(filepath=str(path), update_scene_fps=k == "body", use_fps_scale=k == "hands",
                                    rotate_mode="QUATERNION")
            objs[k] = bpy.context.object
        gc.collect()
    sc = bpy.context.scene
    b0, h0 = core.first_frame(objs["body"]), core.first_frame(objs["hands"])
    hstep = core.take_step(objs["hands"])
    for b, h in PINS:  # what the animator types: the hands scene frame, at the body scene frame
        sc.timeline_markers.new(f"pin:{h0 + h * hstep:g}", frame=int(b0 + b))
    src = objs["body"].animation_data.action
    action, result = core.splice_armatures(objs["body"], objs["hands"], scene=sc)
    return {"bpy": bpy, "objs": objs, "source_action": src, "action": action, "result": result, "core": core}


def test_armature_reads_back_the_bvh_file(scene):
    from splicer.io.bvh import read_bvh

    core = scene["core"]
    body = read_bvh(BODY)
    src = core.armature_motion(scene["objs"]["body"], action=scene["source_action"])
    assert src.n_frames == body.n_frames and src.frame_time == pytest.approx(body.frame_time)
    assert src.skeleton.names == body.skeleton.names
    np.testing.assert_allclose(src.skeleton.offsets, body.skeleton.offsets, atol=1e-4)
    assert _angle(src, body).max() < 1e-3
    hands = core.armature_motion(scene["objs"]["hands"])  # 60 fps take in a 30 fps scene
    assert hands.n_frames == 1985 and hands.fps == pytest.approx(60.0)
    assert _angle(hands, read_bvh(HANDS)).max() < 1e-3


def test_markers_become_pins(scene):
    from splicer.errors import ConstraintError

    core = scene["core"]
    o = scene["objs"]
    cfg = core.markers_to_pins(scene["bpy"].context.scene.timeline_markers, core.first_frame(o["body"]),
                               core.first_frame(o["hands"]), hands_step=core.take_step(o["hands"]))
    # 1985 hands frames at 60 fps in a 30 fps scene: hands frame 347 shows at scene frame 1 + 173.5 ("pin:174.5")
    assert [m.name for m in scene["bpy"].context.scene.timeline_markers if m.name.startswith("pin:")][:2] == \
        ["pin:174.5", "pin:419"]
    assert [(p.body, p.hands) for p in cfg.pairs] == PINS
    assert cfg.tolerance == 2 and all(p.side == "both" for p in cfg.pairs)

    class M:  # a marker as Blender has it: name and frame
        def __init__(self, name, frame):
            self.name, self.frame = name, frame

    cfg = core.markers_to_pins([M("pin:R:40~3", 11), M("clap", 5), M("pin:L:20", 3)], 1, 0)
    assert [(p.body, p.hands, p.tolerance, p.side) for p in cfg.pairs] == [(2, 20, None, "left"), (10, 40, 3, "right")]
    with pytest.raises(ConstraintError, match="pin:x12"):
        core.markers_to_pins([M("pin:x12", 3)], 1, 0)


def test_addon_splice_equals_the_cli(scene, cli_bvh):
    """The fingers baked onto the body armature equal the CLI's output on the same BVH files."""
    core = scene["core"]
    body_obj = scene["objs"]["body"]
    assert body_obj.animation_data.action == scene["action"] != scene["source_action"]
    assert scene["source_action"].name in scene["bpy"].data.actions  # the original is kept, untouched
    baked = core.armature_motion(body_obj)
    assert baked.n_frames == cli_bvh.n_frames and baked.skeleton.names == cli_bvh.skeleton.names
    assert _angle(baked, cli_bvh).max() < 0.01
    # the original action still holds the body take (no fingers spliced into it)
    from splicer.io.bvh import read_bvh

    assert _angle(core.armature_motion(body_obj, action=scene["source_action"]), read_bvh(BODY)).max() < 1e-3
    summary = json.loads(scene["bpy"].context.scene["splicer_report"])
    assert set(summary["sides"]) == {"left", "right"} and summary["sides"]["left"]["pins"] == 4


def test_time_map_fcurve_round_trip_and_reapply(scene):
    core = scene["core"]
    body_obj, result = scene["objs"]["body"], scene["result"]
    first = core.first_frame(body_obj)
    n = result.motion.n_frames
    for side, r in result.sides.items():
        tm = core.fcurve_to_time_map(body_obj, side, n, first)
        np.testing.assert_allclose(tm, r.hands_frame, atol=2e-3)  # float32 keys
    before = core.armature_motion(body_obj)
    # unedited: re-applying reproduces the splice
    again = core.reapply_time_map(body_obj)
    assert _angle(again, before).max() < 0.01
    # edit: hold the left time map on hands frame 500 -> the left fingers freeze on that frame's pose
    fc = core._find_fcurve(scene["action"], body_obj, '["splicer_timemap_left"]')
    for kp in fc.keyframe_points:
        kp.co[1] = 500.0
    fc.update()
    core.reapply_time_map(body_obj)
    after = core.armature_motion(body_obj)
    sk = after.skeleton
    left = [j for j, nm in enumerate(sk.names) if nm.startswith("LeftHand") and any(f in nm for f in FINGERS)]
    right = [j for j, nm in enumerate(sk.names) if nm.startswith("RightHand") and any(f in nm for f in FINGERS)]
    from splicer.model.rotations import quat_angle_deg

    q = after.rotations[:, left]
    assert quat_angle_deg(q, q[:1]).max() < 0.01  # constant over all frames
    assert quat_angle_deg(before.rotations[:, left], q).max() > 5  # and not what it was
    assert quat_angle_deg(before.rotations[:, right], after.rotations[:, right]).max() < 0.01  # right untouched


@pytest.fixture(scope="module")
def fbx_takes(tmp_path_factory):
    """The sample takes exported to FBX by Blender, and read back."""
    from splicer.io.bvh import read_bvh
    from splicer.io.fbx import read_fbx, write_fbx

    d = tmp_path_factory.mktemp("fbx")
    out = {}
    for k, path in (("body", BODY), ("hands", HANDS)):
        write_fbx(read_bvh(path), d / f"{k}.fbx")
        out[k] = (d / f"{k}.fbx", read_fbx(d / f"{k}.fbx"))
    return out


def test_fbx_round_trip_of_the_sample(tmp_path, fbx_takes):
    """Blender's exporter and importer keep the sample to float32 precision, and
    `splice body.fbx hands.fbx -o out.fbx` equals the splice of what the FBX files hold."""
    import splicer
    from splicer.io.bvh import read_bvh
    from splicer.cli import main
    from splicer.io.fbx import read_fbx

    body, hands = read_bvh(BODY), read_bvh(HANDS)
    (bf, rb), (hf, rh) = fbx_takes["body"], fbx_takes["hands"]
    out = tmp_path / "out.fbx"
    for a, b in ((rb, body), (rh, hands)):
        assert a.n_frames == b.n_frames and a.frame_time == pytest.approx(b.frame_time, rel=1e-12)
        assert a.skeleton.names == b.skeleton.names
        np.testing.assert_allclose(a.skeleton.offsets, b.skeleton.offsets, atol=1e-4)
        np.testing.assert_allclose(np.nan_to_num(a.skeleton.end_sites, nan=9e9),
                                   np.nan_to_num(b.skeleton.end_sites, nan=9e9), atol=1e-4)
        assert _angle(a, b).max() < 2e-4
        np.testing.assert_allclose(a.translations[:, 0], b.translations[:, 0], atol=1e-4)
    assert main([str(bf), str(hf), "-o", str(out), "--constraints", str(SYNC), "-q"]) == 0
    got = read_fbx(out)
    ref = splicer.splice(rb, rh, config=SYNC).motion
    assert _angle(got, ref).max() < 0.01
    sk = got.skeleton
    non_finger = [j for j, n in enumerate(sk.names) if not any(f in n for f in FINGERS)]
    assert _angle(got, body)[:, non_finger].max() < 0.01  # the body's own bones, unchanged


def test_fbx_splice_equals_the_bvh_splice(fbx_takes, cli_bvh):
    """FBX keeps rotations to float32 (about 4e-5 degrees); pass 1's expected path is smooth in its
    input, so the splice moves by thousandths of a degree (the best path alone moved up to 1.3
    degrees: benchmarks/noise_robustness.py).  Issue 13 asks for 0.01 degree: measured 0.0079
    (LeftHandMiddle2, body frame 401) since 0.4.0's position term (0.0104 with D1 alone)."""
    from splicer.pipeline import splice

    got = splice(fbx_takes["body"][1], fbx_takes["hands"][1], config=SYNC).motion
    assert _angle(got, cli_bvh).max() < 0.01


def test_missing_bpy_is_one_line(tmp_path):
    """Without bpy, reading an FBX says how to install it (a child Python that cannot see bpy)."""
    code = ("import sys; sys.modules['bpy'] = None\n"
            "import splicer.io.fbx as f; f.have_bpy = lambda: False\n"
            "from splicer.io.motion_io import read_motion\n"
            "try:\n    read_motion(sys.argv[1])\nexcept Exception as e:\n    print(type(e).__name__, e)\n")
    p = tmp_path / "x.fbx"
    p.write_bytes(b"\0")
    r = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, cwd=ROOT,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.stdout.strip() == 'FBXError FBX needs Blender\'s bpy: pip install "splicer[blender]"'


def test_other_suffixes_are_bvh(tmp_path):
    """Only .fbx goes to Blender: any other path is BVH (pipes have no suffix), with the BVH reader's message."""
    from splicer.errors import BVHError
    from splicer.io.motion_io import read_motion

    p = tmp_path / "x.c4d"
    p.write_text("not a motion\n")
    with pytest.raises(BVHError, match="x.c4d"):
        read_motion(p)
    assert read_motion(BODY).n_frames == 601


def test_built_extension_installs_registers_and_splices(tmp_path):
    """`python -m splicer.blender.build` makes a zip that Blender installs and enables; its
    operators splice with the bundled splicer and re-apply the time map."""
    from splicer.blender.build import build

    z = build(tmp_path / "splicer_blender.zip")
    code = f"""import bpy, sys
r = bpy.ops.extensions.package_install_files(filepath={str(z)!r}, repo='user_default', enable_on_install=True)
print('RESULT', sorted(r), hasattr(bpy.types, 'SPLICER_PT_panel'), hasattr(bpy.ops.splicer, 'splice'),
      hasattr(bpy.types.Scene, 'splicer'))
objs = {{}}
for k, path in (('body', {str(BODY)!r}), ('hands', {str(HANDS)!r})):
    bpy.ops.import_anim.bvh(filepath=path, update_scene_fps=k == 'body', use_fps_scale=k == 'hands',
                            rotate_mode='QUATERNION')
    objs[k] = bpy.context.object
st = bpy.context.scene.splicer
st.body, st.hands, st.side = objs['body'], objs['hands'], 'left'
r = bpy.ops.splicer.splice()
print('SPLICE', sorted(r), objs['body'].animation_data.action.name, 'splicer_timemap_left' in objs['body'],
      'bl_ext.user_default.splicer.splicer.pipeline' in sys.modules, 'splicer.pipeline' in sys.modules)
print('REAPPLY', sorted(bpy.ops.splicer.reapply_time_map()))
"""
    home = tmp_path / "home"
    home.mkdir()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                       env={"HOME": str(home), "PATH": "/usr/bin:/bin"}, timeout=300)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith(("RESULT", "SPLICE", "REAPPLY"))]
    assert lines == ["RESULT ['FINISHED'] True True True",
                     "SPLICE ['FINISHED'] sample_body_spliced True True False",  # the bundled copy, not the repo's
                     "REAPPLY ['FINISHED']"], r.stdout[-2000:] + r.stderr[-2000:]


def _tiny_wheel(folder: Path) -> Path:
    """A pure-Python wheel (``splicer_probe``, ``VALUE = 42``), written by hand."""
    import base64
    import hashlib
    import zipfile

    name, ver = "splicer_probe", "0.1"
    files = {f"{name}/__init__.py": "VALUE = 42\n",
             f"{name}-{ver}.dist-info/METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: {ver}\n",
             f"{name}-{ver}.dist-info/WHEEL": "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: py3-none-any\n"}

    def digest(text):
        h = base64.urlsafe_b64encode(hashlib.sha256(text.encode()).digest()).rstrip(b"=").decode()
        return f"sha256={h},{len(text.encode())}"

    files[f"{name}-{ver}.dist-info/RECORD"] = ("".join(f"{k},{digest(v)}\n" for k, v in files.items())
                                              + f"{name}-{ver}.dist-info/RECORD,,\n")
    whl = folder / f"{name}-{ver}-py3-none-any.whl"
    with zipfile.ZipFile(whl, "w") as z:
        for k, v in files.items():
            z.writestr(k, v)
    return whl


def test_bundled_wheels_install_with_the_extension(tmp_path):
    """`--wheels DIR`: the dependency wheels go into the zip and its manifest, and Blender's own
    extension installer (Install from Disk: no terminal) installs them where the add-on imports
    them.  Shown with a tiny wheel; splicer's real dependencies are the same mechanism."""
    from splicer.blender.build import build

    wheels = tmp_path / "wheels"
    wheels.mkdir()
    _tiny_wheel(wheels)
    z = build(tmp_path / "splicer_blender.zip", wheels)
    code = f"""import bpy
r = bpy.ops.extensions.package_install_files(filepath={str(z)!r}, repo='user_default', enable_on_install=True)
import splicer_probe
print('RESULT', sorted(r), splicer_probe.VALUE, '/extensions/' in splicer_probe.__file__)
"""
    home = tmp_path / "home"
    home.mkdir()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=home,
                       env={"HOME": str(home), "PATH": "/usr/bin:/bin"}, timeout=300)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT")]
    assert lines == ["RESULT ['FINISHED'] 42 True"], r.stdout[-2000:] + r.stderr[-2000:]


def test_fbx_with_a_light_a_moving_bone_and_ascii_fbx(tmp_path):
    """Blender 5.0's importer fails on lights (worked around), a bone's own translation is
    warned about, and ASCII FBX is refused (one line)."""
    from splicer.errors import SplicerError
    from splicer.io.fbx import read_fbx

    lit = tmp_path / "lit.fbx"
    code = ("import bpy, sys\n"
            "from splicer.io import fbx\nfrom splicer.io.bvh import read_bvh\n"
            "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
            "m = read_bvh(sys.argv[1]).slice(0, 12)\n"
            "o = fbx.new_armature(m.skeleton, 'a'); fbx.bake_action(o, m)\n"
            "fc = o.animation_data.action.fcurve_ensure_for_datablock(o, 'pose.bones[\"Spine\"].location', index=1)\n"
            "fc.keyframe_points.insert(1, 0.0); fc.keyframe_points.insert(12, 3.0)\n"
            "sc = bpy.context.scene; sc.frame_start, sc.frame_end = 1, 12\n"
            "sc.collection.objects.link(bpy.data.objects.new('lamp', bpy.data.lights.new('lamp', 'POINT')))\n"
            "bpy.ops.export_scene.fbx(filepath=sys.argv[2], object_types={'ARMATURE', 'LIGHT'}, bake_anim=True)\n")
    subprocess.run([sys.executable, "-c", code, str(BODY), str(lit)], capture_output=True, cwd=ROOT,
                   env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}, check=True)
    from splicer.errors import SplicerWarning

    with pytest.warns(SplicerWarning, match=r"lit\.fbx: bones Spine have animated translation; only rotations"):
        m = read_fbx(lit)  # the Spine's own translation is not carried: said, not dropped silently
    assert m.n_frames == 12 and m.skeleton.n_joints == 52
    asc = tmp_path / "ascii.fbx"
    asc.write_text("; FBX 7.4.0 project file\nFBXHeaderExtension:  {\n}\n")
    with pytest.raises(SplicerError, match=r"ascii\.fbx: Blender's FBX importer failed: ASCII FBX files are not "):
        read_fbx(asc)
    with pytest.raises(SplicerError, match=r"nothere\.fbx: no such file"):
        read_fbx(tmp_path / "nothere.fbx")


def test_low_confidence_and_uncovered_ranges_become_timeline_markers(scene):
    core, bpy = scene["core"], scene["bpy"]
    sc = bpy.context.scene
    report = {"sides": {"left": {"low_confidence": [[10, 20], [40, 41]], "uncovered": [[0, 4]]}, "right": {}},
              "body": {"frames": 601}, "hands": {"frames": 1985}, "warnings": ["w1"]}
    core.mark_ranges(sc, report, first=1)
    got = sorted((m.name, m.frame) for m in sc.timeline_markers if m.name.startswith("splicer:"))
    assert got == [("splicer:left low 10-20", 11), ("splicer:left low 40-41", 41), ("splicer:left uncovered 0-4", 1)]
    assert sum(m.name.startswith("pin:") for m in sc.timeline_markers) == len(PINS)  # pins untouched
    core.mark_ranges(sc, {"sides": {"left": {}}}, first=1)  # a new splice replaces the old ranges
    assert not [m for m in sc.timeline_markers if m.name.startswith("splicer:")]
    s = core.report_summary(report)
    assert s["sides"]["left"]["low_confidence"] == [[10, 20], [40, 41]] and s["sides"]["right"]["uncovered"] == []
    assert s["body_frames"] == 601 and s["warnings"] == ["w1"]
