"""Lighting estimators: panorama pixels -> SH radiance coefficients (K, 3), Blender world frame.

Inputs are the pixels ``read_image(..., ldr_as_uint8=True)`` returns: uint8 sRGB for 8-bit LDR files,
float32 linear radiance for HDR (and 16-bit) files.

- ambient:  L_00 of the naive projection only (a constant environment).
- naive:    sRGB -> linear, then the exact projection (no highlight recovery).
- analytic: HDR -> the exact projection; LDR -> sRGB -> linear, clipped highlights re-inflated by the
            physical power-law model of ``highlights``, projection of the recovered map.
- sources:  per-source energy (``sources``): every clipped region gets the energy a model learned from
            real HDR panoramas predicts for it (the expected-error optimum of its predicted ratio).
- keylight: ``sources`` plus explicit key lights: each clipped region that holds a compact sun or lamp
            becomes one light at its centroid, weighed by a clear-sky fit or the per-source model
            (``keylight``; docs/keylight.md has what it gains and what it costs). The default.
- neural:   the paper's learned estimator (LDR -> HDR autoencoder -> lighting encoder) with the shipped
            weights (panolight_core/models), numpy only; HDR inputs are projected exactly.
- auto:     the best estimator available (see ``resolve``).
LDR results are in units of the camera's clip level (1 = white); HDR results in the file's units.
"""
from .basic import ANALYTIC_WORK_HEIGHT, Estimate, ambient, analytic, naive
from .per_source import per_source, per_source_key_lights, with_key_strength, with_pointed_sun, with_sky_sun
from .registry import (
    AUTO,
    BUILTIN,
    DESCRIPTIONS,
    Entry,
    available,
    estimate,
    neural_estimator,
    register_model,
    register_source_model,
    resolve,
)

__all__ = ["ANALYTIC_WORK_HEIGHT", "AUTO", "BUILTIN", "DESCRIPTIONS", "Entry", "Estimate", "ambient", "analytic",
           "available", "estimate", "naive", "neural_estimator", "per_source", "per_source_key_lights",
           "register_model", "register_source_model", "resolve", "with_key_strength", "with_pointed_sun", "with_sky_sun"]
