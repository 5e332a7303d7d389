"""splicer's Blender add-on (an extension for Blender 4.2+): splice the fingers of a hands
armature onto a body armature from a panel (View3D > Sidebar > splicer).

Build the installable zip with ``python -m splicer.blender.build -o splicer_blender.zip``.
The logic is in :mod:`splicer.blender.core` (plain functions, usable without the UI); this
module only registers the operators and the panel, and imports ``bpy`` inside
:func:`register` so that the build command runs without Blender.
"""

_classes = []


def register():
    import bpy

    from . import ui

    _classes[:] = ui.CLASSES
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.splicer = bpy.props.PointerProperty(type=ui.SplicerSettings)


def unregister():
    import bpy

    if hasattr(bpy.types.Scene, "splicer"):
        del bpy.types.Scene.splicer
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _classes.clear()
