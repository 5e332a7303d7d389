"""The add-on's operators and panel (View3D > Sidebar > splicer); logic in :mod:`.core`."""

from __future__ import annotations

import json

import bpy

from . import core


def _is_armature(_self, obj):
    return obj.type == "ARMATURE"


class SplicerSettings(bpy.types.PropertyGroup):
    body: bpy.props.PointerProperty(name="Body", type=bpy.types.Object, poll=_is_armature,
                                    description="Full-body armature (its action is the body take)")
    hands: bpy.props.PointerProperty(name="Hands", type=bpy.types.Object, poll=_is_armature,
                                     description="Armature whose fingers are spliced on (its action is the hands take)")
    side: bpy.props.EnumProperty(name="Sides",
                                 items=[("both", "Both", ""), ("left", "Left", ""), ("right", "Right", "")])
    band1: bpy.props.StringProperty(name="Band", default="30%",
                                    description="Pass-1 band: frames (120), share of the body take (30%) "
                                                "or seconds (20s)")
    merge: bpy.props.EnumProperty(name="Time map", items=[("timemap", "Smooth", "slerp along a smooth time map"),
                                                          ("median", "Median", "the paper's median + blend")])
    wrist: bpy.props.EnumProperty(name="Wrist from", items=[("body", "Body", ""), ("hands", "Hands", "")])
    passes: bpy.props.EnumProperty(name="Passes", items=[("auto", "Auto", "both; pass 1 alone on optical markers"),
                                                         ("both", "Both", ""), ("pass1", "Pass 1", "")])

    def options(self) -> dict:
        return {"side": self.side, "band1": self.band1, "merge": self.merge, "wrist": self.wrist,
                "passes": self.passes}


def _errors():
    return core._sub("errors")


class SPLICER_OT_splice(bpy.types.Operator):
    """Splice the hands armature's fingers onto the body armature as a new action"""

    bl_idname = "splicer.splice"
    bl_label = "Splice"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        s = context.scene.splicer
        return s.body is not None and s.hands is not None and s.body != s.hands

    def execute(self, context):
        s = context.scene.splicer
        try:
            action, result = core.splice_armatures(s.body, s.hands, scene=context.scene, options=s.options())
        except _errors().SplicerError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"spliced into action {action.name!r} ({len(result.report['warnings'])} warnings)")
        return {"FINISHED"}


class SPLICER_OT_reapply(bpy.types.Operator):
    """Re-sample the fingers at the edited time map F-curves (no new alignment)"""

    bl_idname = "splicer.reapply_time_map"
    bl_label = "Re-apply time map"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        b = context.scene.splicer.body
        return b is not None and core.RESULT_PROP in b

    def execute(self, context):
        try:
            core.reapply_time_map(context.scene.splicer.body, scene=context.scene)
        except _errors().SplicerError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}


class SPLICER_OT_add_pin(bpy.types.Operator):
    """Add a pin marker at the current frame: this body frame matches the given hands frame"""

    bl_idname = "splicer.add_pin"
    bl_label = "Add pin here"
    bl_options = {"REGISTER", "UNDO"}
    hands_frame: bpy.props.IntProperty(name="Hands frame", description="Scene frame showing the same instant "
                                       "on the hands armature")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        context.scene.timeline_markers.new(f"pin:{self.hands_frame}", frame=context.scene.frame_current)
        return {"FINISHED"}


class SPLICER_PT_panel(bpy.types.Panel):
    bl_label = "splicer"
    bl_idname = "SPLICER_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "splicer"

    def draw(self, context):
        s = context.scene.splicer
        col = self.layout.column()
        col.prop(s, "body")
        col.prop(s, "hands")
        col.prop(s, "side", expand=True)
        col.prop(s, "band1")
        col.prop(s, "merge")
        col.prop(s, "wrist")
        col.prop(s, "passes")
        pins = [m for m in context.scene.timeline_markers if m.name.startswith("pin:")]
        col.label(text=f"Pins from timeline markers: {len(pins)}")
        col.operator("splicer.add_pin", icon="MARKER_HLT")
        col.operator("splicer.splice", icon="HAND")
        col.operator("splicer.reapply_time_map", icon="GRAPH")
        rep = context.scene.get("splicer_report")
        if rep:
            d = json.loads(rep)
            box = self.layout.box()
            box.label(text=f"Body {d['body_frames']} frames, hands {d['hands_frames']} frames")
            for side, sd in d["sides"].items():
                box.label(text=f"{side}: {sd['joints']} joints, {sd['pins']} pins")
                if sd["uncovered"]:
                    box.label(text="  uncovered: " + ", ".join(f"{a}-{b}" for a, b in sd["uncovered"]), icon="ERROR")
                if sd["low_confidence"]:
                    box.label(text="  low confidence: " + ", ".join(f"{a}-{b}" for a, b in sd["low_confidence"]),
                              icon="QUESTION")
            for w in d["warnings"][:4]:
                box.label(text=w[:90], icon="INFO")


CLASSES = [SplicerSettings, SPLICER_OT_splice, SPLICER_OT_reapply, SPLICER_OT_add_pin, SPLICER_PT_panel]
