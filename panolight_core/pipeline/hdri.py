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
from ..camera.resample import area_downsample, row_blocks
from ..estimators.sources import FullResolutionFill, fill_full_resolution


def hdr_panorama(pixels: np.ndarray, est) -> np.ndarray:
    """(H, W, 3) float32 linear HDR (clip level = 1 for LDR inputs) of panorama ``pixels`` (uint8 sRGB or
    float linear) and its ``estimators.Estimate``."""
    if pixels.dtype != np.uint8:
        return np.asarray(pixels, dtype=np.float32)
    if getattr(est, "recovery", None) is not None:
        return assemble(pixels.shape, hdr_blocks(pixels, est))
    linear = ldr_to_linear(pixels)
    work = est.radiance
    if work is None:
        return linear
    if work.shape == linear.shape:  # a small input: the estimator worked at its full resolution
        return np.maximum(linear, np.asarray(work, dtype=np.float32))
    if work.shape[0] >= pixels.shape[0]:  # upsampled for a network: no cell of it maps to whole pixels
        return linear
    base = area_downsample(linear, work.shape[0], work.shape[1])
    return fill_full_resolution(linear, clipped_mask(pixels), np.maximum(work - base, 0.0))


def assemble(shape, blocks) -> np.ndarray:
    """A float32 image of ``shape`` from row blocks (first row, (n, W, C)), as ``hdr_blocks`` yields them."""
    out = np.empty(shape, np.float32)
    for r0, block in blocks:
        out[r0:r0 + len(block)] = block
    return out


def hdr_blocks(pixels: np.ndarray, est):
    """The rows of ``hdr_panorama`` as (first row, float32 (n, W, 3) block), about 4 M pixels at a time:
    what a writer streams to disk so that a 16K panorama never exists as a full float copy. The
    per-source path is computed block by block; the others are computed whole, then cut."""
    rec = getattr(est, "recovery", None)
    if pixels.dtype == np.uint8 and rec is not None:
        H, W = pixels.shape[:2]
        h = rec.work.shape[0]
        blocks = row_blocks(H, W, max(1, H // h) if H % h == 0 else 1)
        clipped = [clipped_mask(pixels[r0:r1], all_channels=True) for r0, r1 in blocks]  # the per-source regions
        ys = np.concatenate([np.nonzero(c)[0] + r0 for c, (r0, _) in zip(clipped, blocks)])
        xs = np.concatenate([np.nonzero(c)[1] for c in clipped])
        fill = FullResolutionFill((ys, xs), (H, W), np.maximum(rec.work - rec.base, 0.0), rec.regions.centre,
                                  rec.regions.shape_exponents(), rec.regions.labels)
        for (r0, r1), c in zip(blocks, clipped):
            block = ldr_to_linear(pixels[r0:r1])
            fill.apply(block, r0, c)
            yield r0, block
        return
    full = hdr_panorama(pixels, est)
    for r0, r1 in row_blocks(*full.shape[:2]):
        yield r0, full[r0:r1]
