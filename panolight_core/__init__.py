"""PanoLight core: HDR lighting from 360-degree panoramas. numpy-only at import (no bpy, no torch).

The stages, in the order a panorama goes through them:
    camera/      the LDR camera model and its inverse (sRGB, exposure, JPEG)
    estimators/  what the camera clipped: analytic highlights, learned per-source energy, the network
    lighting/    the lighting model: explicit lights + SH at the order the scene needs
    pipeline/    estimate_lighting(pixels, Settings) -> the lighting document; run_estimate: file -> folder
with sh/ (the SH maths), io/ (images and lighting.json), apps/ (the panolight command, batch,
evaluation), metrics (EVALUATION.md) and synthetic (procedural skies and rooms for tests and training).
See docs/development.md.
"""
import logging

__version__ = "0.1.0"

# progress (reading, estimating, writing; the evaluation's scenes) goes to the ``panolight_core`` loggers at
# INFO: silent unless the application configures logging (the panolight command prints it unless -q)
logging.getLogger(__name__).addHandler(logging.NullHandler())
