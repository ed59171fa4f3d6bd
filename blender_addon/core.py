"""The bpy-free core, imported by name: bundled inside the extension zip, or importable in a checkout.

The add-on's modules take what they use from here (``from .core import capture, errors``): plain imports an IDE
follows to their source, in the bundled zip (the first branch) and in a checkout (the second). Only numpy is needed
at import time (image files are read by Blender itself, not by the core's I/O). The bundled copy wins whenever it is
there; an installed panolight_core is used only where the add-on carries none (a development checkout), so an error
inside the bundled core is never hidden by quietly loading another copy.
"""
import importlib.util

if importlib.util.find_spec(f"{__package__}.panolight_core") is not None:
    from . import panolight_core as core
    from .panolight_core import errors, estimators, pipeline, sh, threads
    from .panolight_core.camera import resample, units
    from .panolight_core.estimators import keylight
    from .panolight_core.io import capture, checks, metadata, ownership
    from .panolight_core.io import images as core_images
    from .panolight_core.io import lighting as lighting_file
    from .panolight_core.lighting import lights as core_lights
    from .panolight_core.lighting import order
    from .panolight_core.pipeline import brackets, hdri
    from .panolight_core.pipeline import settings as pipeline_settings
else:  # a development checkout or a pip install: no bundled copy beside this file
    import panolight_core as core
    from panolight_core import errors, estimators, pipeline, sh, threads
    from panolight_core.camera import resample, units
    from panolight_core.estimators import keylight
    from panolight_core.io import capture, checks, metadata, ownership
    from panolight_core.io import images as core_images
    from panolight_core.io import lighting as lighting_file
    from panolight_core.lighting import lights as core_lights
    from panolight_core.lighting import order
    from panolight_core.pipeline import brackets, hdri
    from panolight_core.pipeline import settings as pipeline_settings

# the core modules the add-on uses, as imported above (and so the extension bundles, with what they import:
# scripts/build_extension.py reads this list; a test checks it names what is imported), relative to panolight_core
CORE_MODULES = ("camera.resample", "camera.units", "errors", "estimators", "estimators.keylight", "io.capture", "io.checks",
                "io.images", "io.lighting", "io.metadata", "io.ownership", "lighting.lights", "lighting.order",
                "pipeline", "pipeline.brackets", "pipeline.hdri", "pipeline.settings", "sh", "threads")

__all__ = ["CORE_MODULES", "brackets", "capture", "checks", "core", "core_images", "core_lights", "errors",
           "estimators", "hdri", "keylight", "lighting_file", "metadata", "order", "ownership", "pipeline",
           "pipeline_settings", "resample", "sh", "threads", "units"]
