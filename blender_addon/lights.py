"""Explicit lights of the adaptive model as sun lamps (with their angular size) in the collection "PanoLight
Lights", turned with the lighting (the arithmetic is the core's ``lighting.lights.sun_lamp``). Re-running
replaces PanoLight's own lamps only; a user's object linked into the collection is unlinked, never deleted.
"""
from __future__ import annotations

import bpy
from mathutils import Vector

from .core import core_lights, errors
from .store import TAG, ours

LIGHTS_COLLECTION = "PanoLight Lights"
FLOAT32_MAX = 3.4028234663852886e38


def set_lights(lights, scene, lighting_strength=1.0, lighting_rotation=0.0):
    """Sun lamps for explicit lights (direction = where light comes from, Blender world frame), rotated
    about Z by ``lighting_rotation`` with the lighting; replaces PanoLight's previous lamps only."""
    lamps = [core_lights.sun_lamp(light, lighting_strength, lighting_rotation) for light in lights]
    for lamp in lamps:  # checked before anything changes: Blender keeps a lamp's energy in a float32
        if not 0.0 <= lamp["energy"] <= FLOAT32_MAX:
            raise errors.PanoLightError(f"a sun lamp's strength would be {lamp['energy']:.3g}, beyond what "
                                             f"Blender holds: lower Lighting strength or Sun lamp strength")
    coll = ours(bpy.data.collections, LIGHTS_COLLECTION)
    if coll is None:  # a user's collection of that name is not ours
        coll = bpy.data.collections.new(LIGHTS_COLLECTION)
        coll[TAG] = True
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    for obj in list(coll.objects):
        if not obj.get(TAG):  # a user's object linked here: unlinked from ours, never deleted
            coll.objects.unlink(obj)
            if not obj.users_collection:
                scene.collection.objects.link(obj)
            continue
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        if data is not None and data.users == 0:
            bpy.data.lights.remove(data)
    for i, lamp in enumerate(lamps):
        data = bpy.data.lights.new(f"PanoLight Sun {i}", type="SUN")
        data.energy = lamp["energy"]
        data.color = tuple(float(v) for v in lamp["color"])
        data.angle = lamp["angle"]
        obj = bpy.data.objects.new(f"PanoLight Sun {i}", data)
        obj[TAG] = True
        # a sun shines along its local -Z: point local +Z at the light's direction
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = Vector(lamp["direction"].tolist()).to_track_quat("Z", "Y")
        coll.objects.link(obj)
    return coll
