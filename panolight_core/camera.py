"""Camera / LDR model (EVALUATION.md) and its inverse for LDR inputs.

Forward (how test inputs are made from an HDR panorama P):
  k = 0.18 * 2^ev / median(luminance(P)); LDR = round(255 * srgb(clip(k P, 0, 1))), optionally JPEG q90.
Inverse: sRGB -> linear; clipped energy is not recoverable from pixel values, so ``recover_highlights``
re-inflates saturated regions by a documented model (see its docstring). The estimator never sees k.
"""
from __future__ import annotations

import io as _io

import numpy as np

from .color import linear_to_srgb, luminance, srgb_to_linear

SATURATION_LEVEL = 254.0 / 255.0  # an 8-bit channel at 254 or 255 counts as clipped


def auto_exposure(hdr: np.ndarray, ev: float = 0.0) -> float:
    """k = 0.18 * 2^ev / median(luminance(hdr)) (median over all pixels, unweighted)."""
    med = float(np.median(luminance(np.asarray(hdr, dtype=np.float64))))
    if not med > 0:
        raise ValueError("the median luminance of the HDR image is not positive; auto-exposure is undefined")
    return 0.18 * 2.0 ** ev / med


def hdr_to_ldr(hdr: np.ndarray, ev: float = 0.0, jpeg_quality: int | None = None) -> np.ndarray:
    """(H, W, 3) linear HDR -> (H, W, 3) uint8 sRGB as an auto-exposing camera would (EVALUATION.md)."""
    k = auto_exposure(hdr, ev)
    ldr = np.round(linear_to_srgb(np.clip(k * np.asarray(hdr, dtype=np.float64), 0.0, 1.0)) * 255.0).astype(np.uint8)
    if jpeg_quality is not None:
        from PIL import Image

        buf = _io.BytesIO()
        Image.fromarray(ldr, "RGB").save(buf, format="JPEG", quality=int(jpeg_quality))
        buf.seek(0)
        with Image.open(buf) as im:
            ldr = np.asarray(im.convert("RGB"))
    return ldr


def ldr_to_linear(ldr: np.ndarray) -> np.ndarray:
    """uint8 sRGB (or float sRGB in [0, 1]) -> float32 linear in [0, 1]."""
    a = np.asarray(ldr)
    v = a.astype(np.float32) / 255.0 if a.dtype == np.uint8 else a.astype(np.float32)
    return srgb_to_linear(v).astype(np.float32)
