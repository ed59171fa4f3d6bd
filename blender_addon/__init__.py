"""PanoLight for Blender: estimate HDR lighting from a 360-degree panorama and light the scene with it.

Thin bpy code over the bpy-free core (panolight_core, bundled in the extension zip), the way
glTF-Blender-IO keeps io/ apart from blender/: operators.py gathers settings and calls the core,
the datablock modules turn results into Blender data (store.py: the stored estimate, images.py, world.py:
the node graph, lights.py: sun lamps), batch.py runs it headless.
"""
from __future__ import annotations

import bpy

from . import operators, panel

_CLASSES = panel.CLASSES + operators.CLASSES


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.panolight = bpy.props.PointerProperty(type=panel.PanoLightSettings)


def unregister():
    del bpy.types.Scene.panolight
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
