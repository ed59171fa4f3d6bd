"""Colour helpers: the IEC 61966-2-1 sRGB transfer curve and Rec.709 luminance (numpy; the decoding
curve also takes torch tensors)."""
from __future__ import annotations

import sys

import numpy as np

from .._backend import is_torch

LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])


def srgb_to_linear(v):
    """sRGB-encoded values in [0, 1] -> linear, same shape: numpy (float32 unless float64 came in) or a
    torch tensor (differentiable; the networks' autoencoder uses it)."""
    if is_torch(v):
        where = sys.modules["torch"].where
    else:
        v = np.asarray(v, dtype=np.float32 if np.asarray(v).dtype != np.float64 else np.float64)
        where = np.where
    return where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


SRGB8_TO_LINEAR = srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)  # lookup table for uint8
SRGB8_TO_LINEAR.setflags(write=False)


def linear_to_srgb(v):
    """Linear values -> sRGB-encoded; input is clipped to [0, 1] first."""
    v = np.clip(np.asarray(v), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)


def luminance(rgb):
    """(..., 3) linear Rec.709 RGB -> (...) luminance."""
    return np.asarray(rgb)[..., :3] @ LUMINANCE_WEIGHTS.astype(np.asarray(rgb).dtype)


def gray8(frame: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 sRGB -> (...) uint8: Ward's 8-bit grey, (54 R + 183 G + 19 B) / 256 (the bracket merge's
    alignment bitmaps and its response curve's sampling read it)."""
    grey = np.multiply(frame[..., 0], 54, dtype=np.uint16)  # channel by channel: no (..., 3) uint16 copy (a
    grey += np.multiply(frame[..., 1], 183, dtype=np.uint16)  # strided view's was 6x slower); 256 x 255 fits
    grey += np.multiply(frame[..., 2], 19, dtype=np.uint16)
    grey >>= 8
    return grey.astype(np.uint8)
