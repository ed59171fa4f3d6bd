"""The full-resolution HDR panorama of an estimate (``hdr.exr``): the input, linearised at its own
resolution, with the energy the estimator recovered put back into the clipped pixels.

For an HDR input it is the input (one that clips its own source: with the plateau's restored energy added to the
plateau's pixels, ``sources.restore``). For an LDR it is sRGB -> linear plus the estimator's excess over the
plain linearised work map, cell by cell (``sources.fill_full_resolution``): each work cell's pixel mean
gains exactly the cell's recovered excess, so the HDRI's SH projection equals the estimate's (the
lighting.json model) up to the model's truncation. The per-source estimator shapes the excess like a
source (its glare's power law around the region's centre); other estimators fill the cell's clipped
pixels evenly (all of the cell where nothing clipped, e.g. a network's correction).
"""
from __future__ import annotations

import numpy as np

from .. import threads
from ..camera import ldr_to_linear
from ..camera.color import SRGB8_TO_LINEAR
from ..camera.resample import area_downsample, clipped_pixels, reference_clipped, row_blocks
from ..estimators.sources import FullResolutionFill, fill_full_resolution
from ..packed import PackedImage


def hdr_panorama(pixels: np.ndarray, est) -> np.ndarray:
    """(H, W, 3) float32 linear HDR (clip level = 1 for LDR inputs) of panorama ``pixels`` (uint8 sRGB or
    float linear) and its ``estimators.Estimate``."""
    rec = getattr(est, "recovery", None)
    if pixels.dtype != np.uint8:
        return np.asarray(pixels if rec is None or rec.source is None else rec.source.filled(rec, keys=True),
                          dtype=np.float32)
    if rec is not None:
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
    reference = reference_clipped(pixels, work.shape[0])
    return fill_full_resolution(linear, clipped_pixels(pixels, 0, pixels.shape[0], reference),
                                np.maximum(work - base, 0.0))


def assemble(shape, blocks) -> np.ndarray:
    """A float32 image of ``shape`` from row blocks (first row, (n, W, C)), as ``hdr_blocks`` yields them."""
    out = np.empty(shape, np.float32)
    for r0, block in blocks:
        out[r0:r0 + len(block)] = block
    return out


class HdrRows:
    """The rows of ``hdr_panorama`` times ``scale``: iterate for (first row, float32 (n, W, 3) block), about
    4 M pixels at a time, what a writer streams to disk so that a 16K panorama never exists as a full float
    copy; ``peak``: an upper bound of every value, known before the first block (the writer picks half or
    float32 from it). The per-source path is planned once (a few numbers per region and work cell, whatever
    the number of clipped pixels) and computed block by block on every thread (``threads.imap``: a few blocks
    ahead of the consumer), each block's clipped pixels found again; the others are computed whole, then cut."""

    def __init__(self, pixels: np.ndarray, est, scale: float = 1.0):
        self.pixels, self.scale = pixels, float(scale)
        rec = getattr(est, "recovery", None)
        self.full = self.fill = None
        if pixels.dtype == np.uint8 and rec is not None:
            H, W = pixels.shape[:2]
            h = rec.work.shape[0]
            self.blocks = row_blocks(H, W, max(1, H // h) if H % h == 0 else 1)
            reference = reference_clipped(pixels, h)  # the clipping the regions saw

            def clipped_rows(r0, r1):  # the per-source regions' pixels of rows r0..r1
                return clipped_pixels(pixels[r0:r1], r0, H, reference, all_channels=True)

            self.clipped_rows = clipped_rows
            self.fill = FullResolutionFill(clipped_rows, (H, W), np.maximum(rec.diffuse - rec.base, 0.0),
                                           (rec.regions.centre, rec.regions.shape_exponents(), rec.regions.labels),
                                           rec.key_points())
            self._peak = float(SRGB8_TO_LINEAR[int(pixels.max(initial=0))]) + self.fill.peak()
        else:  # an HDR input (perhaps a packed.PackedImage; restored: its plateau filled) is read block by block
            self.full = (pixels if rec is None or rec.source is None else rec.source.filled(rec, keys=True)
                         ) if pixels.dtype != np.uint8 else hdr_panorama(pixels, est)
            self.blocks = row_blocks(*self.full.shape[:2])
            self._peak = None

    @property
    def peak(self) -> float:
        """An upper bound of every value (NaN and infinities aside)."""
        if self._peak is None and isinstance(self.full, PackedImage):
            self._peak = self.full.peak()
        if self._peak is None:
            self._peak = max((float(np.max(b, initial=0.0, where=np.isfinite(b)))
                              for b in (self.full[r0:r1] for r0, r1 in self.blocks)), default=0.0)
        return self._peak * self.scale

    def fits_half(self) -> bool:
        """Whether half floats hold this HDRI without loss that matters: an 8-bit input (whose 256 levels
        per channel are 20x coarser than half's 11-bit precision; a float input keeps its float32) whose
        darkest step stays a normal half and whose peak stays finite. A 16K hdr.exr is then 151 MB
        instead of 633 MB, and written twice as fast."""
        from ..io.images import HALF_MAX, HALF_MIN_NORMAL

        return (self.pixels.dtype == np.uint8 and self.scale * float(SRGB8_TO_LINEAR[1]) >= HALF_MIN_NORMAL
                and self.peak <= HALF_MAX)

    def _block(self, k: int) -> np.ndarray:
        r0, r1 = self.blocks[k]
        if self.full is not None:
            block = self.full[r0:r1]
        else:
            block = ldr_to_linear(self.pixels[r0:r1])
            self.fill.apply(block, r0, self.clipped_rows(r0, r1))
        if self.scale != 1.0:
            with np.errstate(over="ignore", invalid="ignore"):
                block = block * np.float32(self.scale)
        return block

    def __iter__(self):
        for (r0, _), block in zip(self.blocks, threads.imap(self._block, range(len(self.blocks)))):
            yield r0, block


def hdr_blocks(pixels: np.ndarray, est):
    """``HdrRows(pixels, est)``'s (first row, block) pairs (unscaled)."""
    return iter(HdrRows(pixels, est))


class PeakBeside:
    """(first row, (n, W, 3) block) pairs passed through, as ``HdrRows`` yields them, while ``peak`` records the largest
    Rec.709 luminance of any pixel farther than ``radius`` (radians) from the unit ``direction`` (CONVENTIONS.md frame)
    in the image of ``shape`` (H, W): how bright the panorama is beside a light (Blender's EEVEE keeps the light alone
    above its sun threshold with it). Only the rows the cone crosses get pixel directions, so a 16K panorama costs a
    luminance per pixel. NaN and infinities are passed over. ``peak`` is 0 until the blocks are consumed."""

    def __init__(self, blocks, shape, direction, radius: float):
        self.blocks, (self.height, self.width) = blocks, shape[:2]
        d = np.asarray(direction, dtype=np.float64)
        self.direction, self.cos_radius = d / np.linalg.norm(d), float(np.cos(radius))
        theta = float(np.arccos(np.clip(self.direction[2], -1.0, 1.0)))  # rows centred at pi (r + 0.5) / H
        self.band = (int(np.floor((theta - radius) / np.pi * self.height - 0.5)),
                     int(np.ceil((theta + radius) / np.pi * self.height - 0.5)) + 1)  # rows the cone may cross
        self.peak = 0.0

    def __iter__(self):
        from ..camera.color import LUMINANCE_WEIGHTS
        from ..sh.grid import directions_at

        weights = np.asarray(LUMINANCE_WEIGHTS, dtype=np.float32)
        for r0, block in self.blocks:
            with np.errstate(invalid="ignore", over="ignore"):
                lum = block @ weights
                lum[~np.isfinite(lum)] = 0.0
            b0, b1 = max(self.band[0] - r0, 0), min(self.band[1] - r0, len(block))
            if b0 < b1:  # rows the cone crosses: only their pixels inside it are left out
                rows, cols = np.nonzero(lum[b0:b1] > self.peak)
                inside = directions_at(rows + r0 + b0, cols, self.height, self.width) @ self.direction >= self.cos_radius
                lum[b0:b1][rows[inside], cols[inside]] = 0.0
            self.peak = max(self.peak, float(lum.max(initial=0.0)))
            yield r0, block
