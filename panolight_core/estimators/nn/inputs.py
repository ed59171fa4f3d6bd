"""What the learned estimator sees: an 8-bit panorama reduced to the network's size, with the
physical highlight model's guess attached.

At 64 rows a network pixel averages 8 x 8 pixels of a 1024 x 512 photo, so a clipped sun would vanish
into its unclipped neighbours if the network recomputed saturation from the averaged colour. The input
therefore has 7 channels per cell:
- 0-2: the area average of the linearised pixels, sRGB-encoded (the paper's LDR input);
- 3:   the fraction a of the cell's pixels the camera clipped (brightest channel >= 254);
- 4-6: log b, the clipped pixels' mean excess radiance over the clip level as the analytic estimator's
       power-law recovery (panolight_core.estimators.highlights) puts it, plus 0.05 (so log is finite).
The autoencoder corrects that guess: hdr = linear + a * b * exp(y) (training/neural/models.py), so a network
with y = 0 is exactly the analytic estimator's work map (plus 0.05 a), and training learns where the
physical model is wrong. Unclipped cells (a = 0) pass through unchanged.

A model whose config says ``"guess": "sources"`` gets the per-source estimator's recovered excess in
channels 4-6 instead (its learned energy model: the shipped one, or the file ``"source_model"`` names,
e.g. a cross-validation fold's): that network is a correction of the per-source model, and untrained
it is the per-source model's work map.
"""
from __future__ import annotations

import numpy as np

from ...camera.color import linear_to_srgb
from ...camera.resample import area_downsample
from .. import sources
from ..highlights import WORK_HEIGHT, recover_work_maps, work_maps

CHANNELS = 7
BASE_EXCESS = 0.05


GUESSES = ("analytic", "sources")


def network_input(ldr: np.ndarray, height: int, guess: str = "analytic", source_model=None) -> np.ndarray:
    """(H, 2H, 3) uint8 sRGB panorama -> (7, height, 2 height) float32 (see the module docstring); a
    panorama smaller than the network is upsampled (nearest) first. guess: whose recovered excess fills
    channels 4-6 (GUESSES); source_model: the per-source energy model file for "sources" (default: the
    shipped one)."""
    if guess not in GUESSES:
        raise ValueError(f"guess must be one of {', '.join(GUESSES)}, got {guess!r}")
    ldr = np.asarray(ldr)
    if ldr.dtype != np.uint8 or ldr.ndim != 3 or ldr.shape[-1] != 3:
        raise ValueError(f"network_input wants (H, W, 3) uint8 pixels, got {ldr.dtype} {ldr.shape}")
    if ldr.shape[0] < height:  # smaller than the network: nearest-neighbour upsampling keeps pixels and clipping
        rows = np.arange(height) * ldr.shape[0] // height
        cols = np.arange(2 * height) * ldr.shape[1] // (2 * height)
        ldr = ldr[rows][:, cols]
    maps = work_maps(ldr, height)
    lin, frac = maps[:2]
    if guess == "sources":  # the per-source model's own work maps when the heights agree: made once
        own = maps if height == min(WORK_HEIGHT, ldr.shape[0]) else None
        recovered = lin + _source_excess(ldr, height, source_model, own)
    else:
        recovered, _ = recover_work_maps(lin.copy(), frac)
    frac = frac[..., None]
    excess = np.maximum(recovered - lin, 0.0) / np.maximum(frac, 1e-6) * (frac > 0)
    x = np.concatenate([linear_to_srgb(np.clip(lin, 0.0, 1.0)), frac, np.log(excess + BASE_EXCESS)], axis=-1)
    return np.ascontiguousarray(np.moveaxis(x, -1, 0), dtype=np.float32)


def _source_excess(ldr: np.ndarray, height: int, source_model, maps=None) -> np.ndarray:
    """(height, 2 height, 3) the per-source estimator's recovered excess over the plain linear map, area
    averaged from its own work map (which it computes at its own resolution) to the network's; maps:
    its work maps when the network's height is theirs (sources.recover)."""
    model = sources.load_source_model(source_model) if source_model else None
    rec = sources.recover(ldr, model, maps=maps)
    excess = np.maximum(rec.work - rec.base, 0.0)
    if excess.shape[0] > height:
        return area_downsample(excess, height)
    if excess.shape[0] < height:  # a small input: nearest-neighbour up to the network's cells
        rows = np.arange(height) * excess.shape[0] // height
        return excess[rows][:, np.arange(2 * height) * excess.shape[1] // (2 * height)]
    return excess
