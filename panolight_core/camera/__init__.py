"""Camera / LDR model (EVALUATION.md) and its inverse for LDR inputs.

Forward (how test inputs are made from an HDR panorama P):
  k = 0.18 * 2^ev / median(luminance(P)); LDR = round(255 * srgb(clip(k P, 0, 1))), optionally JPEG q90.
Inverse: sRGB -> linear; clipped energy is not recoverable from pixel values, so ``recover_highlights``
re-inflates saturated regions by a documented model (see its docstring). The estimator never sees k.
"""
from __future__ import annotations

import io as _io

import numpy as np

from .codec import encode_srgb8
from .color import SRGB8_TO_LINEAR, linear_to_srgb, luminance, srgb_to_linear

MID_GREY = 0.18  # the linear value an auto-exposing camera puts its metered median at (EVALUATION.md's k), and the
# value a midtone S-curve turns about (TONE_CURVES "contrast")


def auto_exposure(hdr: np.ndarray, ev: float = 0.0, robust: bool = False) -> float:
    """k = 0.18 * 2^ev / median(luminance(hdr)) (median over all pixels, unweighted).

    robust: when the median is not positive (more than half the pixels black, e.g. a masked sky), use
    the mean luminance instead, and 1 for an all-black image; otherwise such images raise ValueError.
    """
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    med = float(np.median(lum))
    if not med > 0:
        if not robust:
            raise ValueError("the median luminance of the HDR image is not positive; auto-exposure is undefined")
        mean = float(lum.mean())
        return MID_GREY * 2.0 ** ev / mean if mean > 0 else 1.0
    return MID_GREY * 2.0 ** ev / med


TONE_CURVES = {  # name: (what it is, its parameter's default)
    "srgb": ("the sRGB curve (IEC 61966-2-1): EVALUATION.md's camera", None),
    "gamma": ("a pure power law x^(1/gamma), no linear toe (the training camera draws gamma 1.8-2.6)", 2.2),
    "shoulder": ("a soft highlight shoulder x (1 + x / wp^2) / (1 + x), reaching white at wp, then sRGB (the training "
                 "camera draws wp 2-8)", 4.0),
    "contrast": ("a camera's midtone S-curve: 0.18 (x / 0.18)^g, steeper about mid grey (g > 1), then sRGB (not "
                 "drawn in training)", 1.6),
}


def tone_curve(x: np.ndarray, curve: str = "srgb", param: float | None = None) -> np.ndarray:
    """Exposed linear values x (>= 0, 1 = the clip level of the sRGB camera) -> encoded values in [0, 1] through
    one of TONE_CURVES (``param``: gamma, wp or g; None for the curve's default). ValueError naming the curves for
    an unknown one."""
    if curve not in TONE_CURVES:
        raise ValueError(f"unknown tone curve {curve!r}; choose one of {', '.join(TONE_CURVES)}")
    p = TONE_CURVES[curve][1] if param is None else float(param)
    if curve == "srgb":
        return linear_to_srgb(np.clip(x, 0.0, 1.0))
    if curve == "gamma":
        return np.clip(x, 0.0, 1.0) ** (1.0 / p)
    if curve == "shoulder":
        return linear_to_srgb(np.clip(x * (1.0 + x / p ** 2) / (1.0 + x), 0.0, 1.0))
    return linear_to_srgb(np.clip(MID_GREY * (np.maximum(x, 0.0) / MID_GREY) ** p, 0.0, 1.0))


def sensor_noise(x: np.ndarray, rng: np.random.Generator, full_well: float = 10000.0, read: float = 4.0
                 ) -> np.ndarray:
    """Exposed linear values ``x`` (1 = the sensor's white) as a sensor records them: photon (shot) noise of
    ``full_well`` electrons at white (Poisson, taken as Gaussian of variance x full_well) and read noise of ``read``
    electrons (Gaussian), in the same units; not clipped (the tone curve clips). The defaults are a small sensor's
    (a 360 camera's or a phone's: about 10,000 electrons, 4 of read noise)."""
    e = np.maximum(np.asarray(x, dtype=np.float64), 0.0) * full_well
    return (e + rng.standard_normal(e.shape) * np.sqrt(e + read ** 2)) / full_well


def hdr_to_ldr(hdr: np.ndarray, ev: float = 0.0, jpeg_quality: int | None = None, robust: bool = False,
               scale: float | None = None, curve: str = "srgb", curve_param: float | None = None,
               noise: np.random.Generator | None = None) -> np.ndarray:
    """(H, W, 3) linear HDR -> (H, W, 3) uint8 sRGB as an auto-exposing camera would (EVALUATION.md).

    robust: see auto_exposure (for training data with masked or black regions). scale: use this exposure
    factor instead of the automatic one (training code that needs k itself). curve, curve_param: another
    camera's tone curve (``tone_curve``; EVALUATION.md's is "srgb"). noise: a random generator to record the
    exposure through ``sensor_noise`` first (None: a noiseless sensor, EVALUATION.md's)."""
    k = auto_exposure(hdr, ev, robust) if scale is None else float(scale)
    x = k * np.asarray(hdr, dtype=np.float64)
    if noise is not None:
        x = sensor_noise(x, noise)
    ldr = np.round(tone_curve(x, curve, curve_param) * 255.0).astype(np.uint8)
    return ldr if jpeg_quality is None else jpeg_roundtrip(ldr, jpeg_quality)


def jpeg_roundtrip(ldr: np.ndarray, quality: int) -> np.ndarray:
    """(H, W, 3) uint8 -> the same picture saved as a JPEG of that quality and decoded again."""
    from PIL import Image

    with Image.open(_io.BytesIO(encode_srgb8(ldr, "jpeg", quality))) as im:
        return np.asarray(im.convert("RGB"))


def lanczos_resize(ldr: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W, 3) uint8 -> the same picture resampled to (height, width, 3) with a Lanczos filter, as an image editor
    or a web page makes a photo smaller."""
    from PIL import Image

    return np.asarray(Image.fromarray(ldr).resize((int(width), int(height)), Image.LANCZOS))


def ldr_to_linear(ldr: np.ndarray) -> np.ndarray:
    """uint8 sRGB (or float sRGB in [0, 1]) -> float32 linear in [0, 1]."""
    a = np.asarray(ldr)
    if a.dtype == np.uint8:
        return SRGB8_TO_LINEAR[a]
    return srgb_to_linear(a.astype(np.float32)).astype(np.float32)


def linear(pixels: np.ndarray) -> np.ndarray:
    """Panorama pixels as linear radiance: uint8 sRGB through ``ldr_to_linear``, float (HDR) as they are."""
    return ldr_to_linear(pixels) if pixels.dtype == np.uint8 else pixels


def clipped_mask(ldr: np.ndarray, all_channels: bool = False) -> np.ndarray:
    """(H, W) bool: pixels whose brightest uint8 channel is 254 or 255 (clipped by the camera), or with
    ``all_channels`` whose every channel is (white: the per-source estimator's regions)."""
    a = np.asarray(ldr)
    pick = np.minimum if all_channels else np.maximum
    return pick(pick(a[..., 0], a[..., 1]), a[..., 2]) >= 254
