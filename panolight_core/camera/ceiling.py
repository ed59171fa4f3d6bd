"""An HDR file's ceiling: the value at which its merge (or its sensor) clipped a source too bright for every
exposure, as most hand-merged and downloaded HDRIs shot without an ND filter clip their sun.

A clipped source is a plateau: pixels whose channels sit, to the last bits, at the file's largest value in that
channel. Real radiance has no such ties at its peak: of the 111 real HDRs in ../shared/data/hdri only the two
whose sun or lamp core overflowed half floats show three pixels with two or more channels at their maxima, while
a truth clipped at 2, 4 or 6 stops over its JPEG's white shows dozens to thousands (docs/studies/restore.md). A
real un-clipped sun is a peaked disk: it has one brightest pixel, and is never taken for a plateau.

``find_ceiling`` reads the image by row blocks (a ``packed.PackedImage`` too) and returns a ``Ceiling`` or None.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..sh.grid import row_solid_angles
from .color import LUMINANCE_WEIGHTS

CEILING_TOL = 2e-4  # a channel at (1 - this) of its largest value or above sits at the ceiling: float32 and half
# ties are exact; RGBE's 8-bit mantissas differ by at least 1/256 near the top
MIN_PLATEAU_CHANNELS = 2  # a plateau pixel has at least this many channels at their ceilings (a warm sun clips
# red and green before blue; one channel alone ties in real studios' coloured lamps)
MIN_PLATEAU_PIXELS = 3  # ... and a plateau at least this many such pixels (a clipped sun at 1024 x 512 is 1-3
# pixels at +6 stops; 2 tie by chance in 6 real un-clipped HDRs)
MIN_HEADROOM = 8.0  # the ceiling's luminance at least this times the median's: a flat or all-clipped image has
# no source to restore (a JPEG's white is 5.6x its metered median)
BLOCK_ROWS = 256


@dataclass(frozen=True)
class Ceiling:
    """The clip of an HDR image: rgb (3,) the per-channel ceilings (the file's units), the plateau's pixel count
    and solid angle (sr), and its headroom (the ceiling's luminance over the image's median luminance)."""

    rgb: tuple
    pixels: int
    solid_angle: float
    headroom: float

    @property
    def level(self) -> float:
        """The clip unit: the largest channel ceiling (every pixel over it is at most 1 in every channel)."""
        return max(self.rgb)

    def at_ceiling(self, block: np.ndarray) -> np.ndarray:
        """(n, W) int: how many channels of each pixel of a float (n, W, 3) block sit at their ceilings."""
        top = np.asarray(self.rgb, dtype=np.float32) * np.float32(1.0 - CEILING_TOL)
        positive = np.asarray(self.rgb) > 0  # a black channel has no ceiling to sit at
        return ((block >= top) & positive).sum(axis=-1)

    def plateau(self, block: np.ndarray) -> np.ndarray:
        """(n, W) bool: the block's plateau pixels (MIN_PLATEAU_CHANNELS or more channels at their ceilings)."""
        return self.at_ceiling(block) >= MIN_PLATEAU_CHANNELS

    def describe(self) -> dict:
        """For lighting.json: the ceiling per channel, the plateau's pixels and solid angle, the headroom."""
        return {"ceiling": [float(v) for v in self.rgb], "plateau_pixels": int(self.pixels),
                "plateau_sr": round(float(self.solid_angle), 8), "headroom": round(float(self.headroom), 3)}


def _blocks(height: int):
    return [(r, min(height, r + BLOCK_ROWS)) for r in range(0, height, BLOCK_ROWS)]


def find_ceiling(pixels) -> Ceiling | None:
    """The ``Ceiling`` of float linear HDR ``pixels`` (H, W, 3) (an ndarray or a ``packed.PackedImage``), or None
    when it clips nothing: fewer than MIN_PLATEAU_PIXELS plateau pixels, or a ceiling under MIN_HEADROOM times the
    median luminance (over the pixels of every 8th row and column: a gate, not a measurement)."""
    h, w = pixels.shape[:2]
    blocks = _blocks(h)
    top = np.zeros(3)
    samples = []
    for r0, r1 in blocks:
        block = np.asarray(pixels[r0:r1], dtype=np.float32)
        top = np.maximum(top, block.reshape(-1, 3).max(axis=0))
        samples.append(block[::8, ::8].reshape(-1, 3))  # BLOCK_ROWS is a multiple of 8
    if not np.all(np.isfinite(top)) or (top > 0).sum() < MIN_PLATEAU_CHANNELS:
        return None
    ceiling = Ceiling(tuple(float(v) for v in top), 0, 0.0, 0.0)
    count, sr = 0, 0.0
    omega = row_solid_angles(h, w)
    for r0, r1 in blocks:
        rows = ceiling.plateau(np.asarray(pixels[r0:r1], dtype=np.float32)).sum(axis=1)
        count += int(rows.sum())
        sr += float(rows @ omega[r0:r1])
    if count < MIN_PLATEAU_PIXELS:
        return None
    median = float(np.median(np.concatenate(samples) @ LUMINANCE_WEIGHTS))
    headroom = float(top @ LUMINANCE_WEIGHTS) / median if median > 0 else math.inf
    if headroom < MIN_HEADROOM:
        return None
    return Ceiling(ceiling.rgb, count, sr, headroom)
