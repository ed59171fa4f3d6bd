"""The PanoLight panel (World properties, and a PanoLight tab in the 3D viewport sidebar) and settings."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty


class PanoLightSettings(bpy.types.PropertyGroup):
    background_strength: FloatProperty(name="Background strength", default=1.0, min=0.0, soft_max=10.0)
    lighting_strength: FloatProperty(name="Lighting strength", default=1.0, min=0.0, soft_max=10.0)
    background_rotation: FloatProperty(name="Background rotation", subtype="ANGLE", default=0.0)
    lighting_rotation: FloatProperty(name="Lighting rotation", subtype="ANGLE", default=0.0,
                                     description="Turns the SH lighting and the sun lamps together")
    glossy_panorama: BoolProperty(name="Panorama in reflections", default=False,
                                  description="Glossy rays see the panorama instead of the smooth SH lighting")
    create_lights: BoolProperty(name="Sun lamps for explicit lights", default=True)
    radiance_height: IntProperty(name="SH map height", default=256, min=64, max=1024)
    lighting_source: EnumProperty(
        name="Light with", default="SH",
        items=[("SH", "SH lighting + sun lamps", "A smooth SH radiance map plus sun lamps for compact sources"),
               ("HDRI", "Reconstructed HDRI", "Lighting and reflections from the full-resolution HDR panorama, "
                "its clipped sun and lamps filled with their estimated energy")])


def draw_panel(layout, context):
    s = context.scene.panolight
    world = context.scene.world
    col = layout.column(align=True)
    col.operator("panolight.load_panorama", icon="IMAGE_DATA")
    if world is not None and world.get("panolight_panorama"):
        col.label(text=f"Panorama: {world['panolight_panorama']}")
    box = layout.box()
    op = box.operator("panolight.estimate_lighting", icon="LIGHT_SUN")
    box.label(text="Estimated" if world is not None and world.get("panolight_lighting") else "Not estimated yet")
    box = layout.box()
    box.prop(s, "lighting_source")
    box.prop(s, "background_strength")
    box.prop(s, "lighting_strength")
    box.prop(s, "background_rotation")
    box.prop(s, "lighting_rotation")
    box.prop(s, "glossy_panorama")
    box.prop(s, "create_lights")
    box.prop(s, "radiance_height")
    box.operator("panolight.build_environment", icon="WORLD")
    layout.operator("panolight.export_lighting", icon="EXPORT")
    return op


class WORLD_PT_panolight(bpy.types.Panel):
    bl_label = "PanoLight"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    def draw(self, context):
        draw_panel(self.layout, context)


class VIEW3D_PT_panolight(bpy.types.Panel):
    bl_label = "PanoLight"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PanoLight"

    def draw(self, context):
        draw_panel(self.layout, context)


CLASSES = (PanoLightSettings, WORLD_PT_panolight, VIEW3D_PT_panolight)
