"""What the learned estimator sees: an 8-bit panorama reduced to the network's size, with the
physical highlight model's guess attached.

At 64 rows a network pixel averages 8 x 8 pixels of a 1024 x 512 photo, so a clipped sun would vanish
into its unclipped neighbours if the network recomputed saturation from the averaged colour. The input
therefore has 7 channels per cell:
- 0-2: the area average of the linearised pixels, sRGB-encoded (the paper's LDR input);
- 3:   the fraction a of the cell's pixels the camera clipped (brightest channel >= 254);
- 4-6: log b, the clipped pixels' mean excess radiance over the clip level as the analytic estimator's
       power-law recovery (panolight_core.estimators.highlights) puts it, plus 0.05 (so log is finite).
The autoencoder corrects that guess: hdr = linear + a * b * exp(y) (training/models.py), so a network
with y = 0 is exactly the analytic estimator's work map (plus 0.05 a), and training learns where the
physical model is wrong. Unclipped cells (a = 0) pass through unchanged.
"""
from __future__ import annotations

import numpy as np

from ...camera.color import linear_to_srgb
from ..highlights import ldr_work_maps, recover_work_maps

CHANNELS = 7
BASE_EXCESS = 0.05


def network_input(ldr: np.ndarray, height: int) -> np.ndarray:
    """(H, 2H, 3) uint8 sRGB panorama -> (7, height, 2 height) float32 (see the module docstring); a
    panorama smaller than the network is upsampled (nearest) first."""
    ldr = np.asarray(ldr)
    if ldr.dtype != np.uint8 or ldr.ndim != 3 or ldr.shape[-1] != 3:
        raise ValueError(f"network_input wants (H, W, 3) uint8 pixels, got {ldr.dtype} {ldr.shape}")
    if ldr.shape[0] < height:  # smaller than the network: nearest-neighbour upsampling keeps pixels and clipping
        rows = np.arange(height) * ldr.shape[0] // height
        cols = np.arange(2 * height) * ldr.shape[1] // (2 * height)
        ldr = ldr[rows][:, cols]
    lin, frac = ldr_work_maps(ldr, height)
    recovered, _ = recover_work_maps(lin.copy(), frac)
    frac = frac[..., None]
    excess = np.maximum(recovered - lin, 0.0) / np.maximum(frac, 1e-6) * (frac > 0)
    x = np.concatenate([linear_to_srgb(np.clip(lin, 0.0, 1.0)), frac, np.log(excess + BASE_EXCESS)], axis=-1)
    return np.ascontiguousarray(np.moveaxis(x, -1, 0), dtype=np.float32)
