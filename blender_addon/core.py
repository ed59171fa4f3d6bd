"""Access to the bpy-free core: bundled inside the extension zip, or importable in a checkout.

Only numpy is needed at import time (image files are read by Blender itself, not by the core's I/O).
The bundled copy wins whenever it is there; an installed panolight_core is used only where the add-on
carries none (a development checkout), so an error inside the bundled core is never hidden by
quietly loading another copy.
"""
import importlib
import importlib.util

if importlib.util.find_spec(f"{__package__}.panolight_core") is not None:
    from . import panolight_core as core
else:  # a development checkout or a pip install: no bundled copy beside this file
    import panolight_core as core

# the core modules the add-on uses (and so the extension bundles, with what they import:
# scripts/build_extension.py reads this list), relative to panolight_core
CORE_MODULES = ("camera.resample", "errors", "estimators", "io.capture", "io.images", "io.lighting",
                "io.metadata", "io.ownership", "lighting.lights", "lighting.order", "pipeline", "pipeline.hdri",
                "pipeline.settings", "sh", "threads")

for _name in CORE_MODULES:
    importlib.import_module(f"{core.__name__}.{_name}")  # core.io.lighting, core.pipeline.hdri, ...
