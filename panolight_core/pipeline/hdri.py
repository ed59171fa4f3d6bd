"""The full-resolution HDR panorama of an estimate (``hdr.exr``): the input, linearised at its own
resolution, with the energy the estimator recovered put back into the clipped pixels.

For an HDR input it is the input. For an LDR it is sRGB -> linear plus the estimator's excess over the
plain linearised work map, cell by cell (``sources.fill_full_resolution``): each work cell's pixel mean
gains exactly the cell's recovered excess, so the HDRI's SH projection equals the estimate's (the
lighting.json model) up to the model's truncation. The per-source estimator shapes the excess like a
source (its glare's power law around the region's centre); other estimators fill the cell's clipped
pixels evenly (all of the cell where nothing clipped, e.g. a network's correction).
"""
from __future__ import annotations

import numpy as np

from ..camera import clipped_mask, ldr_to_linear
from ..camera.resample import area_downsample
from ..estimators.sources import fill_full_resolution


def hdr_panorama(pixels: np.ndarray, est) -> np.ndarray:
    """(H, W, 3) float32 linear HDR (clip level = 1 for LDR inputs) of panorama ``pixels`` (uint8 sRGB or
    float linear) and its ``estimators.Estimate``."""
    if pixels.dtype != np.uint8:
        return np.asarray(pixels, dtype=np.float32)
    linear = ldr_to_linear(pixels)
    rec = getattr(est, "recovery", None)
    if rec is not None:
        hi = pixels >= 254
        clipped = hi[..., 0] & hi[..., 1] & hi[..., 2]  # the per-source regions are all-channel clipped
        excess = np.maximum(rec.work - rec.base, 0.0)
        return fill_full_resolution(linear, clipped, excess, rec.regions.centre, rec.regions.shape_exponents(),
                                    rec.regions.labels)
    work = est.radiance
    if work is None:
        return linear
    if work.shape == linear.shape:  # a small input: the estimator worked at its full resolution
        return np.maximum(linear, np.asarray(work, dtype=np.float32))
    if work.shape[0] >= pixels.shape[0]:  # upsampled for a network: no cell of it maps to whole pixels
        return linear
    base = area_downsample(linear, work.shape[0], work.shape[1])
    return fill_full_resolution(linear, clipped_mask(pixels), np.maximum(work - base, 0.0))
