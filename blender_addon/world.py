"""The PanoLight world's node graph (world "PanoLight", never the user's own world):

    Texture Coordinate -> Mapping (background rotation) -> Environment Texture (panorama) -> Background (strength)
    Texture Coordinate -> Mapping (lighting rotation)   -> Environment Texture (SH radiance) -> Background (strength)
    Light Path: Is Camera Ray [max Is Glossy Ray] -> Mix Shader factor: 1 shows the panorama, 0 lights with SH

Re-running rebuilds PanoLight's own nodes only.
"""
from __future__ import annotations

import bpy

from .store import TAG, ours

WORLD_NAME = "PanoLight"


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
