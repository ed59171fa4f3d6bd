"""Thin bpy code: images in and out of Blender, the PanoLight world node graph and its sun lamps.

The graph (world "PanoLight", never the user's own world):
    Texture Coordinate -> Mapping (background rotation) -> Environment Texture (panorama) -> Background (strength)
    Texture Coordinate -> Mapping (lighting rotation)   -> Environment Texture (SH radiance) -> Background (strength)
    Light Path: Is Camera Ray [max Is Glossy Ray] -> Mix Shader factor: 1 shows the panorama, 0 lights with SH
Explicit lights of the adaptive model become sun lamps (with their angular size) in the collection
"PanoLight Lights", rotated with the lighting. Re-running rebuilds PanoLight's own nodes and lamps only.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import bpy
import numpy as np

from .core import core

WORLD_NAME = "PanoLight"
LIGHTS_COLLECTION = "PanoLight Lights"
SH_IMAGE_NAME = "PanoLight SH Radiance"
HDRI_IMAGE_NAME = "PanoLight HDRI"
TAG = "panolight"
PANORAMA_KEY = "panolight_panorama"  # world ID property: the panorama image itself (an ID pointer: renames follow)
LIGHTING_KEY = "panolight_lighting"  # world ID property: the estimate, a lighting.json document as JSON
SOURCE_KEY = "panolight_source"  # image ID property: the file an upright copy was made from
ESTIMATE_KEY = "panolight_estimate"  # world and HDRI image ID property: which estimate the HDRI is of


def stored_panorama(world):
    """The panorama image of a PanoLight world, or PanoLightError. Tracked by identity: renaming it keeps
    it, and another image that takes its old name is never taken for it."""
    image = world.get(PANORAMA_KEY) if world else None
    if not isinstance(image, bpy.types.Image):  # removed, or a name stored by an earlier version
        image = None
    if image is None:
        raise core.errors.PanoLightError("no panorama loaded: use Load panorama first")
    return image


def stored_lighting(world) -> dict:
    """The estimate stored on ``world``: a validated lighting document (io.lighting), or PanoLightError."""
    raw = world.get(LIGHTING_KEY) if world else None
    if not raw:
        raise core.errors.PanoLightError("no lighting estimated yet: use Estimate lighting first")
    try:
        doc = json.loads(raw)
    except (TypeError, ValueError):
        raise core.errors.PanoLightError("the stored estimate is not valid JSON: use Estimate lighting again") \
            from None
    return core.io.lighting.validate(doc, "the estimated lighting")


def store_lighting(world, doc: dict | None) -> None:
    """Store an estimate on ``world`` (None forgets it: a new panorama needs a new estimate), with a new
    ESTIMATE_KEY token (the HDRI image made from it carries the same token)."""
    import uuid

    if doc is None:
        world.pop(LIGHTING_KEY, None)
        world.pop(ESTIMATE_KEY, None)
    else:
        world[LIGHTING_KEY] = json.dumps(doc)
        world[ESTIMATE_KEY] = uuid.uuid4().hex


def has_lighting(world) -> bool:
    return bool(world is not None and world.get(LIGHTING_KEY))


def image_pixels(image) -> np.ndarray:
    """(H, W, 3) pixels of a Blender image, top row first: uint8 sRGB for 8-bit images, float32 linear
    for float images (Image.pixels is bottom-up RGBA; 8-bit images come back as sRGB-encoded floats).
    One pixel read; the conversion runs by row blocks, so the only full-size temporary is that read."""
    w, h = image.size
    if w == 0 or h == 0:
        raise core.errors.PanoLightError(f"image {image.name!r} has no pixels (is the file missing?)")
    c = image.channels
    buf = np.empty(w * h * c, dtype=np.float32)
    image.pixels.foreach_get(buf)
    px = buf.reshape(h, w, c)
    out = np.empty((h, w, 3), np.float32 if image.is_float else np.uint8)
    for r0, r1 in core.camera.resample.row_blocks(h, w):  # output rows r0..r1 are input rows h-r1..h-r0
        block = px[h - r1:h - r0, :, :3][::-1]
        if image.is_float:
            out[r0:r1] = block
        else:  # byte images read back as exact k / 255 in [0, 1]: +0.5 and truncation round them
            out[r0:r1] = np.minimum(block * np.float32(255.0) + np.float32(0.5), np.float32(255.0))
    return out


def file_pixels(image):
    """``image_pixels`` read from the image's file by the core's reader (io.images.read_image, on the
    OpenImageIO module Blender ships): the CLI's pixels exactly, with its decode budget, by row blocks
    (a 16K JPEG costs its 0.4 GB of uint8 pixels, not a 2.1 GB RGBA float read). None for a packed,
    generated or edited image, or a missing file: Blender's own pixels are then read."""
    source = image.get(SOURCE_KEY)  # PanoLight's upright copy of a turned file: read the file itself
    if source is None:
        if image.source != "FILE" or image.packed_file is not None or image.is_dirty:
            return None
        source = bpy.path.abspath(image.filepath)
    path = Path(source)
    if not path.is_file():
        return None
    return core.io.images.read_image(path, ldr_as_uint8=True)


def upright_panorama(filepath: str, pixels: np.ndarray):
    """PanoLight's own packed float image of a file Blender would show turned (an EXIF orientation, a
    Radiance ``+Y`` file: Blender ignores both): the core's upright linear pixels (H, W, 3), so the
    background and the estimate agree. The file's path is kept (``file_pixels`` reads it again)."""
    h, w = pixels.shape[:2]
    image = bpy.data.images.new(Path(filepath).name, w, h, alpha=False, float_buffer=True)
    image[TAG] = "panorama"
    image[SOURCE_KEY] = str(filepath)
    image.colorspace_settings.name = "Linear Rec.709"
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = pixels[::-1]  # Blender's rows are bottom-up
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


def ours(collection, name: str):
    """PanoLight's own datablock of a kind: the one carrying its tag (renamed or not), preferring ``name``.
    A user's datablock that merely has the name is never returned."""
    tagged = [d for d in collection if d.get(TAG)]
    return next((d for d in tagged if d.name == name), tagged[0] if tagged else None)


def load_panorama(filepath: str):
    """PanoLight's own image of ``filepath``, with the right colour space: Linear Rec.709 for HDR files
    (EXR, Radiance), sRGB for the rest (8-bit and 16-bit PNG/JPEG: Blender keeps 16-bit PNGs in float
    buffers, but they are sRGB-encoded). An image of the same file the user already has is left as it
    is (its colour space is theirs): PanoLight loads its own copy, tagged, and reuses it next time.

    The colour space is chosen from the file's first bytes and set before Blender decodes the pixels
    (``image.file_format`` decodes them, and a colour space change drops them again: an 8K JPEG was
    decoded twice)."""
    target = bpy.path.abspath(filepath)
    space = "Linear Rec.709" if core.io.images.sniff_format(target) in ("exr", "hdr") else "sRGB"
    for image in bpy.data.images:
        if image.get(TAG) == "panorama" and bpy.path.abspath(image.filepath) == target:
            image.reload()
            break
    else:
        image = bpy.data.images.load(filepath, check_existing=False)
        image[TAG] = "panorama"
    if image.colorspace_settings.name != space:
        image.colorspace_settings.name = space
    return image


def own_image(name: str):
    """PanoLight's float image made under ``name`` (SH_IMAGE_NAME or HDRI_IMAGE_NAME), even if renamed."""
    return next((im for im in bpy.data.images if im.get(TAG) == name), None)


def radiance_image(radiance, name: str = SH_IMAGE_NAME, shape=None):
    """Create or update a packed float image (the SH radiance map, or the reconstructed HDRI with
    ``name=HDRI_IMAGE_NAME``) from (H, W, 3) linear pixels, top row first, or from row blocks
    (first row, (n, W, 3)) of an image of ``shape`` (H, W): the HDRI is filled block by block."""
    if shape is None:
        radiance = np.asarray(radiance)
        h, w = radiance.shape[:2]
        blocks = [(0, radiance)]
    else:
        (h, w), blocks = shape, radiance
    image = own_image(name)
    if image is not None and tuple(image.size) != (w, h):
        bpy.data.images.remove(image)
        image = None
    if image is None:  # a user's image that has the name keeps it; ours becomes "name.001"
        image = bpy.data.images.new(name, w, h, alpha=False, float_buffer=True)
        image[TAG] = name
    image.colorspace_settings.name = "Linear Rec.709"
    rgba = np.ones((h, w, 4), dtype=np.float32)
    for r0, block in blocks:  # Blender's rows go bottom-up
        n = block.shape[0]
        rgba[h - r0 - n:h - r0, :, :3] = block[::-1]
    image.pixels.foreach_set(rgba.ravel())
    del rgba
    image.pack()
    return image


def panolight_world():
    """The PanoLight world (created once; the user's worlds are never modified)."""
    world = ours(bpy.data.worlds, WORLD_NAME)
    made = world is None
    if made:  # a user's world named "PanoLight" keeps its name and nodes
        world = bpy.data.worlds.new(WORLD_NAME)
        world[TAG] = True
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    if made:
        world.node_tree.nodes.clear()  # Blender's default nodes of a world PanoLight just made
    return world


def _socket(sockets, identifier):
    for s in sockets:
        if s.identifier == identifier:
            return s
    raise KeyError(identifier)


def build_world(panorama, sh_image=None, *, background_strength=1.0, lighting_strength=1.0,
                background_rotation=0.0, lighting_rotation=0.0, glossy_panorama=False):
    """(Re)build the PanoLight node graph; returns the world. Without ``sh_image`` the panorama lights too."""
    world = panolight_world()
    nt = world.node_tree
    for node in list(nt.nodes):  # only PanoLight's nodes: a node the user added stays
        if node.get(TAG):
            nt.nodes.remove(node)

    def new_node(kind):
        node = nt.nodes.new(kind)
        node[TAG] = True
        return node

    out = new_node("ShaderNodeOutputWorld")
    out.is_active_output = True
    out.location = (900, 0)
    coord = new_node("ShaderNodeTexCoord")
    coord.location = (-900, 0)

    def branch(image, rotation, strength, y, label):
        mapping = new_node("ShaderNodeMapping")
        mapping.location = (-700, y)
        mapping.label = f"{label} rotation"
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, rotation)
        tex = new_node("ShaderNodeTexEnvironment")
        tex.location = (-450, y)
        tex.label = label
        tex.image = image
        bg = new_node("ShaderNodeBackground")
        bg.location = (-150, y)
        bg.label = f"{label} strength"
        bg.inputs["Strength"].default_value = strength
        nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
        return bg

    bg_panorama = branch(panorama, background_rotation, background_strength, 250, "Panorama")
    bg_light = branch(sh_image or panorama, lighting_rotation, lighting_strength, -250, "Lighting")
    path = new_node("ShaderNodeLightPath")
    path.location = (-150, 600)
    mix = new_node("ShaderNodeMixShader")
    mix.location = (500, 0)
    fac = _socket(mix.inputs, "Fac")
    if glossy_panorama:
        both = new_node("ShaderNodeMath")
        both.operation = "MAXIMUM"
        both.location = (200, 500)
        nt.links.new(path.outputs["Is Camera Ray"], both.inputs[0])
        nt.links.new(path.outputs["Is Glossy Ray"], both.inputs[1])
        nt.links.new(both.outputs["Value"], fac)
    else:
        nt.links.new(path.outputs["Is Camera Ray"], fac)
    shaders = [s for s in mix.inputs if s.type == "SHADER"]
    nt.links.new(bg_light.outputs["Background"], shaders[0])  # factor 0: everything but camera rays
    nt.links.new(bg_panorama.outputs["Background"], shaders[1])  # factor 1: camera (and glossy) rays
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    return world


def set_lights(lights, scene, lighting_strength=1.0, lighting_rotation=0.0):
    """Sun lamps for explicit lights (direction = where light comes from, Blender world frame), rotated
    about Z by ``lighting_rotation`` with the lighting; replaces PanoLight's previous lamps only."""
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
    c, s = math.cos(lighting_rotation), math.sin(lighting_rotation)
    for i, light in enumerate(lights):
        d = np.asarray(light["direction"], dtype=float)
        d = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])  # follows the Mapping rotation
        data = bpy.data.lights.new(f"PanoLight Sun {i}", type="SUN")
        data.energy = float(light["intensity"]) * lighting_strength
        data.color = tuple(float(v) / max(max(light["color"]), 1e-12) for v in light["color"])
        data.energy *= max(light["color"])  # keep the colour's scale in the strength
        data.angle = float(light.get("angle", 0.0))
        obj = bpy.data.objects.new(f"PanoLight Sun {i}", data)
        obj[TAG] = True
        # a sun shines along its local -Z: point local +Z at the light's direction
        obj.rotation_mode = "QUATERNION"
        from mathutils import Vector

        obj.rotation_quaternion = Vector(d.tolist()).to_track_quat("Z", "Y")
        coll.objects.link(obj)
    return coll
