"""Restoring an HDR file's clipped source: the plateau ``camera.ceiling`` finds is weighed by the same per-source
and key-light machinery as a photo's clipped sun, and only its pixels change.

The file is read in clip units (the ceiling's largest channel is 1), so its plateau is what a camera's white is
to the trees. Its work maps are the file's own linear pixels, area-averaged (no 8-bit quantisation, no tone
curve), and the clipped fractions count the plateau's pixels. Every pixel off the plateau keeps its value to the
bit in ``hdr.exr`` and in the radiance the lighting model is fitted to: the recovered energy is added to the
plateau's pixels only (``fill.FullResolutionFill``), in the file's units.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import sh
from ...camera.ceiling import MIN_PLATEAU_CHANNELS, Ceiling, row_runs
from ...camera.resample import area_downsample, block_of, block_starts
from ...packed import PackedImage, RowFile
from ..highlights import WORK_HEIGHT
from .fill import FullResolutionFill


@dataclass(frozen=True)
class Source:
    """The HDR a recovery restores: its float pixels (H, W, 3) (an ndarray or ``packed.PackedImage``), in the
    file's units, and their ``Ceiling``. The recovery's maps and energies are in clip units: times ``level``."""

    pixels: object
    ceiling: Ceiling
    _projections: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def level(self) -> float:
        return self.ceiling.level

    def projection(self, lmax: int) -> np.ndarray:
        """(K, 3) float64: the exact SH projection of the pixels as they are (made once per order)."""
        if lmax not in self._projections:
            self._projections[lmax] = sh.project(self.pixels, lmax).astype(np.float64)
        return self._projections[lmax]

    def plateau_rows(self, r0: int, r1: int) -> np.ndarray:
        """(r1 - r0, W) bool: the plateau pixels of rows r0..r1 (the pixels the restoration fills)."""
        return self.ceiling.row_counts(self.pixels, r0, r1) >= MIN_PLATEAU_CHANNELS

    def work_maps(self, height: int = WORK_HEIGHT):
        """(rad (h, 2h, 3) float64 in clip units, frac_any, frac_all (h, 2h)) as ``highlights.work_maps`` makes
        them of a photo: the area means of the pixels over ``level``, of the pixels with a channel at its ceiling,
        and of the plateau's pixels; h = min(height, H). The fractions read only the ceiling's rows."""
        H, W = self.pixels.shape[:2]
        h = min(height, H)
        w = 2 * h
        rad = area_downsample(self.pixels, h) / self.level
        cell_pixels = np.diff(block_starts(H, h))[:, None] * np.diff(block_starts(W, w))[None, :]
        counts = np.zeros((2, h, w))
        row_cell, col_cell = block_of(H, h), block_of(W, w)
        for r0, r1 in row_runs(np.asarray(self.ceiling.rows, dtype=np.int64)):
            k = self.ceiling.at_ceiling(np.asarray(self.pixels[r0:r1], dtype=np.float32))
            y, x = np.nonzero(k)
            cy = row_cell[y + r0]
            np.add.at(counts[0], (cy, col_cell[x]), 1.0)
            plateau = k[y, x] >= MIN_PLATEAU_CHANNELS
            np.add.at(counts[1], (cy[plateau], col_cell[x[plateau]]), 1.0)
        return rad, counts[0] / cell_pixels, counts[1] / cell_pixels

    def filled(self, rec, keys: bool) -> PackedImage:
        """The restored panorama in the file's units, read by row blocks: the pixels, plus on the plateau the
        energy recovery ``rec`` (a ``sources.Recovery`` of ``work_maps``) put back beyond them, with its key lights
        (``keys``: what ``hdr.exr`` holds) or without (the diffuse radiance the lighting model is fitted to)."""
        excess = np.maximum((rec.diffuse - rec.base) * self.level, 0.0)
        points = [(d, e * self.level) for d, e in rec.key_points()] if keys else []
        fill = FullResolutionFill(self.plateau_rows, self.pixels.shape[:2], excess,
                                  (rec.regions.centre, rec.regions.shape_exponents(), rec.regions.labels), points)
        return PackedImage(FilledRows(self, fill), "file")


class FilledRows(RowFile):
    """The rows of a ``Source``'s pixels with a ``FullResolutionFill`` applied: a ``packed.PackedImage`` store
    (kind "file", read by slices and gathers as a ``RowFile``), made again at each access, so no full-size copy of a
    large panorama exists. Blocks are made in parallel (no file to serialise on)."""

    def __init__(self, source: Source, fill: FullResolutionFill):
        super().__init__(None, *source.pixels.shape[:2])
        self.source, self.fill = source, fill
        pixels = source.pixels
        peak = pixels.peak() if isinstance(pixels, PackedImage) else float(np.max(pixels, initial=0.0))
        self.top = peak + fill.peak()  # an upper bound, what hdr.exr's writer needs

    def _rows(self, r0: int, r1: int) -> np.ndarray:
        block = np.array(self.source.pixels[r0:r1], dtype=np.float32)
        self.fill.apply(block, r0, self.source.plateau_rows(r0, r1))
        return block
