"""Merging a bracket set: several 8-bit exposures of one scene -> one linear HDR panorama (numpy only: Blender
runs it too).

Each frame is decoded through the sRGB curve (EVALUATION.md's camera; a set's own response curve is not recovered)
and divided by its relative exposure; the frames are averaged with Debevec's hat weight of the pixel's **worst**
channel, so a pixel clipped in one channel of a frame takes nothing from that frame (a clipped channel averaged in
makes a dark sun or a magenta halo). A pixel clipped in every frame is clipped: it is set to the darkest frame's
white in every channel, which makes the merged file an HDR that clips its own sun at exactly its ceiling
(``camera.ceiling``), and the restoration weighs it as for any such file.

Units: the reference frame's white is 1 (the frame whose exposure is the set's median: the ev-0 JPEG of a
{-2, 0, +2} set), so the merged panorama is in the same units as that JPEG's estimate; the ceiling is the
reference's exposure over the darkest frame's (4 for {-2, 0, +2}).
"""
from __future__ import annotations

import math

import numpy as np

from .. import threads
from ..errors import PanoLightError
from .color import SRGB8_TO_LINEAR

CLIPPED_CODE = 250  # a channel at this 8-bit code or above is clipped: a JPEG's compression leaves a clipped sun's
# pixels at 250-253 as often as at 255 (noon_grass at -2 ev, q90: 2812 pixels at 254 or more, 3138 at 250), and a
# frame's near-white pixel weighs almost nothing by the hat anyway
MIN_EXPOSURE_STEP = 2.0 ** (1.0 / 3.0)  # two frames whose exposures differ less than a third of a stop are one
BLOCK_ROWS = 256


def exposure(time_s: float, f_number: float, iso: float) -> float:
    """A frame's relative exposure: ExposureTime x ISO / FNumber^2 (cameras change the ISO inside a bracket, so
    the time alone is not the exposure). PanoLightError for a value that is not a positive finite number."""
    for name, value in (("ExposureTime", time_s), ("FNumber", f_number), ("ISO", iso)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise PanoLightError(f"{name} {value!r} is not a positive number")
    return float(time_s) * float(iso) / float(f_number) ** 2


def hat(codes: np.ndarray) -> np.ndarray:
    """Debevec's hat weight of 8-bit codes (float32): 1 at 0 rising to 128 at mid-scale and falling again, 0 at
    CLIPPED_CODE or above."""
    z = codes.astype(np.float32)
    return np.where(codes >= CLIPPED_CODE, np.float32(0.0), np.minimum(z + 1.0, 256.0 - z))


def check_exposures(exposures) -> np.ndarray:
    """(n,) float64 relative exposures, each pair at least MIN_EXPOSURE_STEP apart; else PanoLightError."""
    e = np.asarray(exposures, dtype=np.float64)
    if e.ndim != 1 or e.size < 2 or not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise PanoLightError(f"a bracket set needs two or more positive exposures, got {list(exposures)}")
    s = np.sort(e)
    if np.any(s[1:] / s[:-1] < MIN_EXPOSURE_STEP):
        raise PanoLightError("two frames of the set have exposures less than a third of a stop apart "
                             f"(relative exposures {', '.join(f'{v:.4g}' for v in e)}): a bracket set's exposures "
                             f"must differ (give them with --evs if the files' EXIF is wrong)")
    return e


def merge_brackets(frames, exposures) -> tuple[np.ndarray, dict]:
    """Merge 8-bit sRGB frames (each (H, W, 3) uint8, one scene, aligned) taken at relative ``exposures`` into
    a float32 (H, W, 3) linear HDR (units: the reference frame's white is 1) and what was done: the reference frame
    (index), each frame's exposure over the reference's (in stops), the ceiling, and the share of pixels clipped in
    every frame."""
    e = check_exposures(exposures)
    shapes = {np.asarray(f).shape for f in frames}
    if len(frames) != e.size or len(shapes) != 1 or any(np.asarray(f).dtype != np.uint8 for f in frames):
        raise PanoLightError(f"a bracket set is frames of one size, 8-bit, one per exposure (got {len(frames)} "
                             f"frames of shapes {sorted(shapes)}, {e.size} exposures)")
    ref = int(np.argsort(e)[(e.size - 1) // 2])
    rel = e / e[ref]
    ceiling = float(1.0 / rel.min())
    weight = hat(np.arange(256, dtype=np.uint8))  # by code: a table lookup per pixel, not arithmetic
    radiance = [(SRGB8_TO_LINEAR / np.float32(k)).astype(np.float32) for k in rel]  # each frame's code -> radiance
    h = frames[0].shape[0]
    out = np.empty(frames[0].shape, np.float32)

    def merge_rows(rows):
        r0, r1 = rows
        num = np.zeros((r1 - r0,) + frames[0].shape[1:], np.float32)
        den = np.zeros((r1 - r0, frames[0].shape[1]), np.float32)
        for frame, lut in zip(frames, radiance):
            block = frame[r0:r1]
            w = weight[np.maximum(np.maximum(block[..., 0], block[..., 1]), block[..., 2])]
            num += w[..., None] * lut[block]
            den += w
        none = den == 0  # clipped in every frame: at the darkest frame's white
        num /= np.where(none, np.float32(1.0), den)[..., None]
        num[none] = np.float32(ceiling)
        out[r0:r1] = num
        return int(none.sum())

    clipped = sum(threads.map_ordered(merge_rows, [(r, min(h, r + BLOCK_ROWS)) for r in range(0, h, BLOCK_ROWS)]))
    return out, {"reference": ref, "stops": [round(math.log2(k), 4) for k in rel], "ceiling": ceiling,
                 "clipped_in_every_frame": clipped / float(out.shape[0] * out.shape[1])}
