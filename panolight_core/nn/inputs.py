"""What the learned estimator sees: an 8-bit panorama reduced to the network's size.

At 64 rows a network pixel averages 8 x 8 pixels of a 1024 x 512 photo, so a clipped sun would vanish
into its unclipped neighbours if the network recomputed saturation from the averaged colour. The input
therefore carries 4 channels: the area average of the linearised pixels, sRGB-encoded (the paper's LDR
input), and the fraction of each cell's pixels the camera clipped (``camera.clipped_mask``). The
autoencoder adds the clipped energy back as ``fraction * excess`` (training/models.py), which is exact
for a cell whose clipped pixels have mean radiance 1 + excess.
"""
from __future__ import annotations

import numpy as np

from ..camera import clipped_mask, ldr_to_linear
from ..color import linear_to_srgb
from ..resample import area_downsample

CHANNELS = 4


def network_input(ldr: np.ndarray, height: int) -> np.ndarray:
    """(H, 2H, 3) uint8 sRGB panorama -> (4, height, 2 height) float32: sRGB colour in [0, 1] and the
    clipped fraction in [0, 1], both area-averaged (colour in linear light)."""
    ldr = np.asarray(ldr)
    if ldr.dtype != np.uint8 or ldr.ndim != 3 or ldr.shape[-1] != 3:
        raise ValueError(f"network_input wants (H, W, 3) uint8 pixels, got {ldr.dtype} {ldr.shape}")
    lin = area_downsample(ldr_to_linear(ldr), height)
    frac = area_downsample(clipped_mask(ldr)[..., None].astype(np.float32), height)
    x = np.concatenate([linear_to_srgb(np.clip(lin, 0.0, 1.0)), frac], axis=-1)
    return np.ascontiguousarray(np.moveaxis(x, -1, 0), dtype=np.float32)
