"""PanoLight's Blender layer (thin bpy code over panolight_core).

Kept apart from the bpy-free core the way glTF-Blender-IO separates io/ from blender/. The panel,
the "Estimate lighting" operator and the headless batch entry point are built in the Blender
extension issue; this package holds no operators yet.
"""
